"""Seeing the swarm: one scene (FLSs, paths, moves), drawn as a PNG or sent to a viewer."""
