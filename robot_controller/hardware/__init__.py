"""What stands between the loop and a real arm's controller: ``franka_server``, the stand-in Franka robot (a third
party's server speaking libfranka's protocol, MuJoCo inside) with our own Panda in it, for libfranka's client side."""
