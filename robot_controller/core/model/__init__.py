"""The arm: its URDF model and coupled dynamics, the MuJoCo plant, payloads,
identification, and the simulated drive and encoder."""
