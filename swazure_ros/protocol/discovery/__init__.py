"""Distributed path discovery: one FLS's part of the protocol of docs/protocol.md.

- :mod:`.messages`: what the coordinator and the FLSs say (controls, offers, reports);
- :mod:`.search`: one FLS's labels in one phase, relaxed round by round in buckets;
- :mod:`.estimate`: a source's phase results made into section 5's estimates;
- :mod:`.participant`: one FLS's state machine over whole runs.
"""
