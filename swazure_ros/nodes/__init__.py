"""rclpy nodes of a swarm: one :mod:`.fls_node` per FLS, the :mod:`.world_node`, and the
per-process :mod:`.host` that brings nodes up, keeps the world replica and waits for
discovery. Message conversions live in :mod:`.convert`.
"""
