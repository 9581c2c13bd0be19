"""
Studies at scale (``vibrissa batch``), ROS-free: the ``batch`` extra alone runs them.

``study`` parses and expands study files into tasks, ``batch`` runs the tasks on Dask distributed,
``dataset`` writes and reads the Parquet dataset they produce.
"""
