"""
What ``vibrissa scan`` reads and writes, and the figures.

``scan_io`` is the CSV / JSON contract of scans, ``scene_file`` reads and writes scene YAML,
``scene_scan`` is what ``vibrissa scan --scene`` and a study's scene task run, and ``plots``
draws scans, scenes and sweeps; ``scene_scan3d``, ``scan_io3d`` and ``plots3d`` are the same for
the 3D whisker (``vibrissa scan --scene`` with 3D poses).
"""
