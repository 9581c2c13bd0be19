"""
Independent checks: second solvers that validate the product's solvers, never used by them.

Each shares nothing with the solver it checks but the problem statement: ``shooting`` checks the
exact family's closed forms, ``general_shooting`` the general whisker's collocation, and
``scene_shooting`` the scenes' several contacts, by shooting on the rod's ODEs with
``scipy.integrate.solve_ivp`` and ``scipy.optimize.root``. Tests and benchmarks import them; no
product path (tracker, node, CLI, studies) does, and a test checks that.
"""
