"""Conversions between the core's and the protocol's data and ROS messages.

Each message type converts in one module of this package, and only there,
both ways where both are needed; every conversion of a message from the
network checks what arrived (ids, codes, lengths, finite numbers).

- :mod:`.units`: vectors, stamps and the metre/centimetre boundary;
- :mod:`.sensing`: measurements, detections, camera images, world revisions;
- :mod:`.discovery`: controls, offers, estimates, acks, moves, path walks;
- :mod:`.tracking`: relay requests, samples, track estimates and progress;
- :mod:`.markers`: a scene as RViz markers.
"""
