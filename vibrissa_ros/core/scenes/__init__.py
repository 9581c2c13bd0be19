"""
Scenes: several obstacles, several contacts at once, corners and Coulomb friction.

``boundary`` describes obstacle boundaries as arcs and corners (signed distances, nearest
features), ``scene`` validates a scene and answers its geometric queries, ``multicontact`` solves
the whisker's equilibrium against several contacts (piecewise Chebyshev collocation, stick/slip),
and ``tracker`` follows them along the foot's path with every event located. A one-obstacle
scene without friction reproduces :mod:`vibrissa_ros.core.exact` to the last digit.
"""
