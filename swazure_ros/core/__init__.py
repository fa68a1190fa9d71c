"""The Swazure model as a numpy/scipy library, with no ROS dependency.

Modules, each holding one idea of ``docs`` / the spec:

- :mod:`.clouds`: point clouds from files and built-in shapes;
- :mod:`.sensor`: sensor ranges and error model;
- :mod:`.camera`: a rendering ArUco camera (OpenCV), and :mod:`.calibration`,
  the sensor derived from it;
- :mod:`.draws`: counter-based random draws;
- :mod:`.geometry`: radius, dmin, collision removal, tracking distance;
- :mod:`.neighbours`: neighbour pairs and their range classes;
- :mod:`.sight`: line of sight and obstructing FLSs;
- :mod:`.paths`: neighbour graphs and path policies;
- :mod:`.metrics`: error metrics of estimates;
- :mod:`.evaluate`: the batch evaluation of every ordered blind pair.
"""

from .errors import SwazureError

__all__ = ["SwazureError"]
