"""The rendering camera, above the model: OpenCV renders, detects and solves here only.

- :mod:`.aruco`: a rendering ArUco camera: render a marker, detect it, solve its pose;
- :mod:`.calibration`: the sensor derived from the camera by sweeps.
"""
