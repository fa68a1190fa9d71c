"""The Swazure model as a numpy/scipy/numba library: no ROS, no OpenCV, no files.

Modules, each holding one idea of ``docs`` / the spec:

- :mod:`.clouds`: built-in shapes, validating and resampling point clouds;
- :mod:`.sensor`: sensor ranges and error model;
- :mod:`.sensor_file`: a sensor file's mapping as a sensor;
- :mod:`.hop_errors`: measured hop vectors and their expected errors;
- :mod:`.draws`: counter-based random draws;
- :mod:`.geometry`: radius, dmin, collision removal, tracking distance;
- :mod:`.circles`: circles in space, free of blocking spheres, crossing a sphere;
- :mod:`.segments`: points and segments, distances to segments;
- :mod:`.neighbours`: neighbour pairs and their range classes;
- :mod:`.grid`: the uniform grid of points and the scan of a segment;
- :mod:`.sight`: line of sight and obstructing FLSs;
- :mod:`.graph`: neighbour graphs in CSR form;
- :mod:`.path_arrays`: many paths in one record, their hops and sums;
- :mod:`.search`: one search from one source (the kernels under :mod:`.paths`);
- :mod:`.paths`: the path policies over many pairs at once;
- :mod:`.metrics`: error metrics of estimates;
- :mod:`.progress`: how a long stage tells its progress;
- :mod:`.neighbourhood`: what every pair evaluation of a swarm shares: pairs, sight, graphs;
- :mod:`.hops`: what the hops of many paths measure;
- :mod:`.evaluation`: each blind pair's results and the run's evaluation;
- :mod:`.pair_statistics`: the run's metrics, gathered block by block;
- :mod:`.evaluate`: the batch evaluation of every ordered blind pair;
- :mod:`.least_squares`: the weighted least-squares solve of positions from measurements;
- :mod:`.fit_measurements`: which measurements a fit takes;
- :mod:`.window_fit`: a source's own fit over what it hears;
- :mod:`.swarm_edges`: the swarm's fit's measured pairs as directed edges;
- :mod:`.conjugate_gradients`: the swarm's conjugate gradients, by exchanges and exact sums;
- :mod:`.swarm_fit`: the swarm's own fit, its robust schedule and covariance;
- :mod:`.pair_fits`: the engine's least-squares estimates of many pairs;
- :mod:`.fit`: the estimators, and an evaluation refined by a fit;
- :mod:`.relay`: tracking's relay choice and relayed samples;
- :mod:`.estimators`: a tracked target's motion from relayed samples;
- :mod:`.tracking`: a source's track of a relayed stream, and its errors;
- :mod:`.metric_rows`: a comparison's rows of the summaries' numbers;
- :mod:`.pair_classes`: a comparison by class of pairs;
- :mod:`.compare`: runs compared side by side.
"""

from .errors import SwazureError

__all__ = ["SwazureError"]
