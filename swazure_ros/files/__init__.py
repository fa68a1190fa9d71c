"""Reading the files people give and writing the files the project makes.

- :mod:`.reading`: regular files of bounded size, YAML of bounded expansion, ``config/``;
- :mod:`.sensors`: sensor, camera and measured-camera files;
- :mod:`.cloud_files`: point clouds from files (.xyz, .csv, .npy, .ply) or built-in shapes;
- :mod:`.description`: a swarm's description, which names its cloud and sensor files;
- :mod:`.results`: atomic writes, pairs tables, summaries and run records.
"""
