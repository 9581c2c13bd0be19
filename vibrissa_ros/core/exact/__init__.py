"""
The paper's exact planar model: a uniform elastica solved in closed form (elliptic integrals).

``elastica`` holds the closed forms of the tip-loaded elastica (paper §2, eqs. (3)-(23)),
``models`` the elastica and the rigid one-link model (paper §3) behind one interface,
``tracker`` the quasistatic tracker that follows a contact along the foot's path (phases, events,
snap-off), ``inverse`` the contact point from one base-wrench reading. This is the fast path and
the yardstick of every other solver.
"""
