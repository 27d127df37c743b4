"""What the arm is asked to do: trajectories, waypoint trajectories and their quintic
paths, and whether the arm can follow them."""
