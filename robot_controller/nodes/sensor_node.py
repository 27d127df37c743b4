"""sensor_node: the encoder. Samples ``/sim/joint_states`` on a ``rate_hz`` grid of its stamps, adds
seeded noise (and ``delay_s``) and publishes ``/joint_states`` stamped with the sample's time; and, latched, the
arm's URDF on ``/robot_description`` (as robot_state_publisher does), for ROS clients such as MoveIt."""

from __future__ import annotations

import numpy as np
from sensor_msgs.msg import JointState
from std_msgs.msg import String

from robot_controller import parameters as cfg
from robot_controller import resources
from robot_controller.core.model import DelayLine, load_model, measure
from robot_controller.core.model.mujoco_model import joint_units
from robot_controller.ros.messages import check_joint_state, s_to_stamp, stamp_to_s
from robot_controller.ros.process import run
from robot_controller.ros.qos import LATCHED_QOS, LOCKSTEP_READINGS_QOS, loop_qos
from robot_controller.ros.stack_node import StackNode

# Stamps within this of a grid point count as on it (float ns rounding).
_GRID_EPS_S = 1e-6
# A stamp this far before the sampling grid restarts it (a future-stamped message may have set the grid).
RESYNC_S = 1.0


class SensorNode(StackNode):
    def __init__(self) -> None:
        super().__init__("sensor_node")
        seed = self.params["seed"]
        self.rng = np.random.default_rng(None if seed < 0 else seed)
        self.sensor = cfg.sensor_config(self.params)
        self.delay_line = DelayLine(self.sensor.delay_s)
        self.period_s = 1.0 / self.params["rate_hz"]
        self.next_sample_s: float | None = None
        self.joint_names: list[str] | None = None
        self.pub = self.gated_publisher(
            JointState, "/joint_states", qos=LOCKSTEP_READINGS_QOS if self.lockstep else None
        )
        self.create_subscription(JointState, "/sim/joint_states", self.true_state_callback, loop_qos(self.lockstep))
        self.watch_single_publisher("/sim/joint_states", "simulator")
        self.out = JointState()
        urdf = resources.resolve_urdf(self.params["urdf_path"])
        self.description_pub = self.create_publisher(String, "/robot_description", LATCHED_QOS)
        self.description_pub.publish(String(data=urdf.read_text()))
        units = " or ".join(dict.fromkeys(joint_units(load_model(urdf))))
        self.get_logger().info(
            f"sensor at {self.params['rate_hz']:g} Hz: σ position {self.sensor.position_noise_std:g} {units}, "
            f"σ velocity {self.sensor.velocity_noise_std:g} {units.replace('rad', 'rad/s').replace('m', 'm/s')}, "
            f"seed {seed}" + (f", {self.sensor.delay_s * 1e3:g} ms late" if self.sensor.delay_s else "")
        )

    def check_params(self, params: dict) -> None:
        cfg.sensor_config(params)

    def apply_params(self, params: dict, changed: set[str]) -> None:
        self.sensor = cfg.sensor_config(params)
        self.delay_line.delay_s = self.sensor.delay_s
        self.period_s = 1.0 / params["rate_hz"]

    def true_state_callback(self, msg: JointState) -> None:
        stamp_s = stamp_to_s(msg.header.stamp)
        if self.next_sample_s is not None and stamp_s < self.next_sample_s - _GRID_EPS_S:
            if stamp_s > self.next_sample_s - self.period_s - RESYNC_S:
                return  # between samples
            # Far behind: a bogus (far-future) stamp set the grid, or the simulator restarted: follow the stamps.
            behind_s = self.next_sample_s - stamp_s
            self.warn_throttled(
                "resync",
                f"/sim/joint_states stamp {stamp_s:.3f} s is {behind_s:.3f} s behind the "
                "sampling grid: re-synchronised",
            )
        if self.joint_names is None:
            self.joint_names = list(msg.name)
        checked = check_joint_state(msg.name, msg.position, msg.velocity, self.joint_names)
        if isinstance(checked, str):
            self.warn_throttled("true_state", f"/sim/joint_states unusable: {checked}")
            return
        # Next grid point after this stamp (skips ahead if the sim published sparsely).
        grid_index = np.floor((stamp_s + _GRID_EPS_S) / self.period_s)
        self.next_sample_s = (grid_index + 1) * self.period_s
        position, velocity, stamp = checked[0], checked[1], msg.header.stamp
        if self.sensor.delay_s > 0:
            sample_s, position, velocity = self.delay_line.push(stamp_s, position, velocity)
            stamp = s_to_stamp(sample_s)
        position, velocity = measure(self.sensor, position, velocity, self.rng)
        out = self.out
        out.header.stamp = stamp
        out.name = self.joint_names
        out.position = position.tolist()
        out.velocity = velocity.tolist()
        self.pub.publish(out)


def main(args: list[str] | None = None) -> int:
    return run(SensorNode, args)


if __name__ == "__main__":
    raise SystemExit(main())
