"""Simulation of the physical world the nodes live in: positions, camera and radio."""
