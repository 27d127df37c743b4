"""The graph spec: every port of the loop and every ROS interface the product serves or uses. This is the one module
that spells a topic name (``spec.READING.topic``), so a topic is renamed, re-typed or recorded in one line. Plain data:
no ROS in it, so the core, scoring and tests read it as well. The names (``/joint_states``, ``/trajectory``, …) are the
tutorial's and ros2_controllers'; users' clients depend on them, so they never change."""

from __future__ import annotations

from dataclasses import dataclass

#: The QoS classes a port may name; ``ros.qos.profile`` maps each to its profile in each clock mode, and says why.
QOS_CLASSES = ("control", "latest", "loop", "readings", "latched", "readings_writer", "clock", "frames")

#: When the recorder records a port.
NEVER, ALWAYS, SIM_TIME = "never", "always", "sim_time"

#: ``writer`` of a port anyone may write: an operator's tool or any ROS client.
ANYONE = "anyone"
# ``{controller_name}`` in a name is the planner parameter ``controller_name`` (ros2_controllers' controller name).


@dataclass(frozen=True)
class Port:
    """One topic of the graph, named for what it carries."""

    name: str  #: what it carries, as blocks name their inputs and outputs
    topic: str  #: the ROS topic; ``{controller_name}`` is filled by :meth:`topic_for`
    msg_type: str  #: the ROS type, ``package/msg/Name``
    writer: str  #: the node that writes it (or :data:`ANYONE`)
    qos: str = "control"  #: the QoS class of the reader that acts on it (:data:`QOS_CLASSES`)
    writer_qos: str = "control"  #: the QoS class of its writer
    partition: bool = False  #: in the run's DDS partition (a foreign writer is never heard)
    public: bool = False  #: in the partition (whatever ``partition`` says), written in the default one too
    recorded: str = ALWAYS  #: when the recorder records it (:data:`SIM_TIME`: on sim time only; :data:`NEVER`)
    scored: bool = False  #: read back from the bag by scoring

    def __post_init__(self) -> None:
        if self.public:
            object.__setattr__(self, "partition", True)

    def topic_for(self, controller_name: str) -> str:
        """The topic for the planner parameter ``controller_name`` (the topic itself if it names none)."""
        return self.topic.format(controller_name=controller_name)


@dataclass(frozen=True)
class Service:
    """A ROS service a node of the product serves."""

    name: str
    service: str  #: the ROS service name
    srv_type: str  #: ``package/srv/Name``
    server: str


@dataclass(frozen=True)
class Action:
    """A ROS action a node of the product serves."""

    name: str
    action: str  #: the ROS action name; ``{controller_name}`` is filled by :meth:`action_for`
    action_type: str  #: ``package/action/Name``
    server: str

    def action_for(self, controller_name: str) -> str:
        return self.action.format(controller_name=controller_name)


_FLOATS = "std_msgs/msg/Float64MultiArray"
_JOINT_STATE = "sensor_msgs/msg/JointState"
_BOOL = "std_msgs/msg/Bool"
_JOINT_TRAJECTORY = "trajectory_msgs/msg/JointTrajectory"
_STRING = "std_msgs/msg/String"
_CLOCK = "rosgraph_msgs/msg/Clock"
_DIAGNOSTICS = "diagnostic_msgs/msg/DiagnosticArray"

# The loop.
#: ``[q…, q̇…, q̈…, time_s]``, the reference (the tutorial's ``[q…, q̇…]`` accepted too)
REFERENCE = Port("reference", "/trajectory", _FLOATS, "trajectory_planner", "loop", partition=True, scored=True)
#: the sensor's noisy readings, stamped with the sample time
READING = Port(
    "reading", "/joint_states", _JOINT_STATE, "sensor_node", "readings", "readings_writer", public=True, scored=True
)
#: a camera's joint positions (``--sensing both``), stamped with the exposure, each σ in ``header.frame_id``
#: (``blocks.values.position_std_label``)
CAMERA_READING = Port(
    "camera_reading", "/vision/joint_states", _JOINT_STATE, "vision_node", "readings", "readings_writer", partition=True
)
#: the camera's image of the arm, RGB, stamped with its exposure (never recorded: 0.9 MB a frame)
IMAGE = Port(
    "image",
    "/camera/image_raw",
    "sensor_msgs/msg/Image",
    "camera_node",
    "frames",
    "frames",
    partition=True,
    recorded=NEVER,
)
#: the camera's intrinsics, with each image (as image pipelines expect)
CAMERA_INFO = Port("camera_info", "/camera/camera_info", "sensor_msgs/msg/CameraInfo", "camera_node", partition=True)
#: the image with the markers found outlined, JPEG, a few a second: what the view shows and the bag keeps
DETECTIONS = Port(
    "detections", "/camera/detections/compressed", "sensor_msgs/msg/CompressedImage", "vision", partition=True
)
#: the controller's torque, N·m per joint (its tick's stamp in the layout's first dimension)
COMMAND = Port("command", "/joint_commands", _FLOATS, "pid_controller", "loop", partition=True)
#: the drive's torque applied to the world, N·m per joint
EFFORT = Port("effort", "/sim/effort", _FLOATS, "motor_node", "loop", partition=True)
#: the world's true state (q, q̇, applied effort), stamped with its physics time
TRUE_STATE = Port("true_state", "/sim/joint_states", _JOINT_STATE, "simulator", "loop", partition=True, scored=True)
#: every term of the controller's tick (``core.controller.state_layout``)
STATE = Port("state", "/controller/state", _FLOATS, "pid_controller", partition=True, scored=True)

# Telemetry and safety.
#: the controller's timing over the last second
DIAGNOSTICS = Port("diagnostics", "/diagnostics", _DIAGNOSTICS, "pid_controller", partition=True)
#: rows of ``[receipt_time_s, command…]``, once a second
COMMAND_RECEIPTS = Port(
    "command_receipts", "/motor/command_receipts", _FLOATS, "motor_node", partition=True, scored=True
)
#: 1 = a joint's brake engaged; why, in the label (``engaged:drive_timeout``). Each change is an event kept in order
#: (not the latest alone): a controller stopped while the brakes engaged and let go must still hear that they held.
BRAKES = Port("brakes", "/sim/brakes", _FLOATS, "simulator", "control", partition=True, scored=True)
#: the drive's brake request (a state, latched)
BRAKE_REQUEST = Port("brake_request", "/sim/brake", _BOOL, "motor_node", "latched", "latched", partition=True)
#: true = stop; outside every partition: a stop is heard from anyone
ESTOP = Port("estop", "/estop", _BOOL, ANYONE, "latest")
#: ``[torque_nm…, duration_s]``, an external torque asked for
DISTURBANCE = Port("disturbance", "/sim/disturbance", _FLOATS, ANYONE, "latest", partition=True)
#: ``[torque_nm…, time_s]`` while an external torque acts, one zero row after
DISTURBANCE_APPLIED = Port(
    "disturbance_applied", "/sim/disturbance_applied", _FLOATS, "simulator", partition=True, scored=True
)
#: the sim's time, as fast as it goes (``--sim-time``) and in the paced world (clients on ``use_sim_time`` hear it)
CLOCK = Port("clock", "/clock", _CLOCK, "simulator", "latched", "clock", public=True, recorded=SIM_TIME)
#: sim time: the tick the recorder has taken (the simulator holds while it lags)
RECORDER_CLOCK = Port("recorder_clock", "/recorder/clock", _CLOCK, "recorder", "clock", "clock", recorded=NEVER)

# The arm's face to ROS clients.
#: a waypoint trajectory replacing the planner's motion, in the run's partition (the project's tools)
WAYPOINTS = Port(
    "waypoints", "/trajectory_planner/joint_trajectory", _JOINT_TRAJECTORY, ANYONE, "latest", partition=True
)
#: the same, as JointTrajectoryController's topic, outside every partition
CONTROLLER_WAYPOINTS = Port(
    "controller_waypoints", "/{controller_name}/joint_trajectory", _JOINT_TRAJECTORY, ANYONE, "latest", recorded=NEVER
)
#: the arm's URDF, latched (as robot_state_publisher's)
ROBOT_DESCRIPTION = Port(
    "robot_description", "/robot_description", _STRING, "sensor_node", "latched", "latched", recorded=NEVER
)
#: every node's log lines (rclpy's): where a rejected goal's reason is read back
ROSOUT = Port("rosout", "/rosout", "rcl_interfaces/msg/Log", ANYONE, recorded=NEVER)

# The launchers' clock exchange across hosts (``nodes.graph_watch``).
CLOCK_PROBE_REQUEST = Port(
    "clock_probe_request", "/clock_probe/request", _STRING, "graph_watch", partition=True, recorded=NEVER
)
CLOCK_PROBE_REPLY = Port(
    "clock_probe_reply", "/clock_probe/reply", _STRING, "graph_watch", partition=True, recorded=NEVER
)

#: Bags from before the command receipts: the motor's latency, s (read if there, written no more).
LEGACY_COMMAND_LATENCY = Port(
    "command_latency", "/motor/command_latency", _FLOATS, "motor_node", scored=True, recorded=NEVER
)

#: Every port, in the order declared.
PORTS = tuple(value for value in tuple(globals().values()) if isinstance(value, Port))

#: the simulator's e-stop button (true = stop), as ``robot-controller estop`` presses it
ESTOP_SERVICE = Service("estop_button", "/simulator/estop", "std_srvs/srv/SetBool", "simulator")
#: the planner's FollowJointTrajectory action, as JointTrajectoryController serves it (MoveIt's client)
FOLLOW_JOINT_TRAJECTORY = Action(
    "follow_joint_trajectory",
    "/{controller_name}/follow_joint_trajectory",
    "control_msgs/action/FollowJointTrajectory",
    "trajectory_planner",
)
SERVICES = (ESTOP_SERVICE,)
ACTIONS = (FOLLOW_JOINT_TRAJECTORY,)


def port(name: str) -> Port:
    for candidate in PORTS:
        if candidate.name == name:
            return candidate
    raise KeyError(f"no port {name!r}; the spec has {', '.join(p.name for p in PORTS)}")


def partition_topics() -> tuple[str, ...]:
    """Every topic in the run's DDS partition (``ros.partition`` writes a profile for each)."""
    return tuple(p.topic for p in PORTS if p.partition)


def public_topics() -> tuple[str, ...]:
    """Partition topics written in the default partition too: any ROS client may hear them."""
    return tuple(p.topic for p in PORTS if p.public)


def recorded_ports(sim_time: bool) -> tuple[Port, ...]:
    """What the recorder records: every :data:`ALWAYS` port, and the :data:`SIM_TIME` ones on sim time."""
    return tuple(p for p in PORTS if p.recorded == ALWAYS or (sim_time and p.recorded == SIM_TIME))


def scored_topics() -> tuple[str, ...]:
    return tuple(p.topic for p in PORTS if p.scored)


#: The blocks each node of the graph may run, by the name its ``block`` parameter gives (the first without one):
#: ``module:Class`` (``blocks.block.make_block`` imports only the one chosen).
BLOCKS: dict[str, dict[str, str]] = {
    "motor_node": {"drive": "robot_controller.blocks.drive:Drive"},
    "pid_controller": {"controller": "robot_controller.blocks.controller:Controller"},
    "trajectory_planner": {"planner": "robot_controller.blocks.planner:Planner"},
    "sensor_node": {
        "encoder": "robot_controller.blocks.encoder:Encoder",
        "every_other_tick": "robot_controller.blocks.every_other_tick:EveryOtherTick",
        "vision": "robot_controller.blocks.vision:Vision",
    },
    "camera_node": {"camera": "robot_controller.blocks.camera:Camera"},
    "vision_node": {"vision": "robot_controller.blocks.vision:VisionBeside"},
}
