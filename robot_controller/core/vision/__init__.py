"""Closing the loop through a camera, without ROS: a fixed pinhole camera, ArUco markers on the arm's links, the
arm rendered offscreen by MuJoCo, the markers detected in the image and every joint angle estimated at once from
their corners by least squares over the kinematic chain."""
