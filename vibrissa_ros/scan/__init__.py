"""
What ``vibrissa scan`` reads and writes, and the figures.

``scan_io`` is the CSV / JSON contract of scans, ``scene_file`` reads and writes scene YAML,
``scene_scan`` is what ``vibrissa scan --scene`` and a study's scene task run, and ``plots``
draws scans, scenes and sweeps.
"""
