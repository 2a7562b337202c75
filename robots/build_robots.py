"""Generates the primitive-geometry URDFs in this folder (``python robots/build_robots.py``), and
``humanoid.urdf.xacro``, the humanoid with xacro arguments for variants (seed 000's 20-DOF exercise).

Why a generator: masses, inertias and collision shapes must agree with each other; writing them by hand
invites copy-paste errors. Inertias come from the solid box / cylinder / sphere formulas, so each link's
inertia tensor is exactly that of its collision shape at its mass.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path

HERE = Path(__file__).resolve().parent

COLOURS: dict[str, tuple[float, float, float, float]] = {
    "grey": (0.55, 0.57, 0.60, 1.0),
    "dark": (0.20, 0.22, 0.25, 1.0),
    "blue": (0.20, 0.40, 0.80, 1.0),
    "orange": (0.95, 0.55, 0.15, 1.0),
    "white": (0.92, 0.92, 0.92, 1.0),
    "red": (0.80, 0.20, 0.20, 1.0),
    "green": (0.25, 0.70, 0.35, 1.0),
    "skin": (0.95, 0.80, 0.65, 1.0),
}


def fmt(*values: float) -> str:
    # Round to 6 decimals and drop "-0" so the files diff cleanly.
    return " ".join(f"{0.0 if abs(v) < 5e-7 else round(v, 6):g}" for v in values)


@dataclass
class Shape:
    kind: str  # box | cylinder | sphere
    dims: tuple[float, ...]  # box (x, y, z); cylinder (radius, length); sphere (radius,)
    xyz: tuple[float, float, float] = (0.0, 0.0, 0.0)
    rpy: tuple[float, float, float] = (0.0, 0.0, 0.0)

    def geometry_xml(self) -> str:
        if self.kind == "box":
            return f'<box size="{fmt(*self.dims)}"/>'
        if self.kind == "cylinder":
            return f'<cylinder radius="{fmt(self.dims[0])}" length="{fmt(self.dims[1])}"/>'
        return f'<sphere radius="{fmt(self.dims[0])}"/>'

    def inertia(self, mass: float) -> tuple[float, float, float]:
        """Principal moments (ixx, iyy, izz) of the solid shape in its own frame."""
        if self.kind == "box":
            x, y, z = self.dims
            return (mass / 12 * (y * y + z * z), mass / 12 * (x * x + z * z), mass / 12 * (x * x + y * y))
        if self.kind == "cylinder":
            r, h = self.dims
            side = mass / 12 * (3 * r * r + h * h)
            return (side, side, mass * r * r / 2)
        r = self.dims[0]
        return (0.4 * mass * r * r,) * 3


@dataclass
class Link:
    name: str
    mass: float
    shape: Shape
    colour: str = "grey"

    def xml(self) -> str:
        s = self.shape
        ixx, iyy, izz = s.inertia(self.mass)
        # Shapes are either unrotated or rotated by ±90° about one axis: permute the moments accordingly.
        if abs(s.rpy[0]) > 1e-9:  # about x: y <-> z
            iyy, izz = izz, iyy
        if abs(s.rpy[1]) > 1e-9:  # about y: x <-> z
            ixx, izz = izz, ixx
        origin = f'<origin xyz="{fmt(*s.xyz)}" rpy="{fmt(*s.rpy)}"/>'
        return (
            f'  <link name="{self.name}">\n'
            f"    <inertial>\n"
            f'      <origin xyz="{fmt(*s.xyz)}" rpy="0 0 0"/>\n'
            f'      <mass value="{fmt(self.mass)}"/>\n'
            f'      <inertia ixx="{fmt(ixx)}" ixy="0" ixz="0" iyy="{fmt(iyy)}" iyz="0" izz="{fmt(izz)}"/>\n'
            f"    </inertial>\n"
            f"    <visual>\n      {origin}\n      <geometry>{s.geometry_xml()}</geometry>\n"
            f'      <material name="{self.colour}"/>\n    </visual>\n'
            f"    <collision>\n      {origin}\n      <geometry>{s.geometry_xml()}</geometry>\n    </collision>\n"
            f"  </link>\n"
        )


@dataclass
class Joint:
    name: str
    kind: str  # revolute | continuous | fixed | prismatic
    parent: str
    child: str
    xyz: tuple[float, float, float] = (0.0, 0.0, 0.0)
    rpy: tuple[float, float, float] = (0.0, 0.0, 0.0)
    axis: tuple[float, float, float] = (0.0, 0.0, 1.0)
    lower: float = 0.0
    upper: float = 0.0
    effort: float = 0.0
    velocity: float = 0.0
    damping: float = 0.0
    mimic: tuple[str, float, float] | None = None

    def xml(self, effort: str | None = None, velocity: str | None = None) -> str:
        """The <joint> element; ``effort`` / ``velocity`` replace the limit numbers (xacro expressions)."""
        effort = fmt(self.effort) if effort is None else effort
        velocity = fmt(self.velocity) if velocity is None else velocity
        lines = [
            f'  <joint name="{self.name}" type="{self.kind}">',
            f'    <parent link="{self.parent}"/>',
            f'    <child link="{self.child}"/>',
            f'    <origin xyz="{fmt(*self.xyz)}" rpy="{fmt(*self.rpy)}"/>',
        ]
        if self.kind != "fixed":
            lines.append(f'    <axis xyz="{fmt(*self.axis)}"/>')
            if self.kind == "continuous":
                lines.append(f'    <limit effort="{effort}" velocity="{velocity}"/>')
            else:
                lines.append(
                    f'    <limit lower="{fmt(self.lower)}" upper="{fmt(self.upper)}" '
                    f'effort="{effort}" velocity="{velocity}"/>'
                )
            if self.damping:
                lines.append(f'    <dynamics damping="{fmt(self.damping)}" friction="0"/>')
        if self.mimic:
            joint, multiplier, offset = self.mimic
            lines.append(f'    <mimic joint="{joint}" multiplier="{fmt(multiplier)}" offset="{fmt(offset)}"/>')
        lines.append("  </joint>\n")
        return "\n".join(lines)


IMU_AXES_NOISE = {   # Gazebo's usual IMU noise (its sensor tutorials' values): gyro and accelerometer
    "angular_velocity": (2e-4, 7.5e-6, 8e-7),
    "linear_acceleration": (1.7e-2, 0.1, 1e-3),
}
IMU_INTERFACES = [f"orientation.{a}" for a in "xyzw"] + [f"{q}.{a}" for q in IMU_AXES_NOISE for a in "xyz"]
FT_INTERFACES = [f"{q}.{a}" for q in ("force", "torque") for a in "xyz"]


@dataclass
class SensorDecl:
    """A sensor as a ROS user declares it: ``<ros2_control><sensor>`` plus ``<gazebo reference><sensor>``."""

    name: str
    kind: str          # imu | force_torque | contact
    reference: str     # a link (imu, contact) or the measured joint (force_torque)
    frame_id: str      # the TF frame its readings are in
    update_rate: float = 1000.0

    def ros2_control_xml(self) -> str:
        interfaces = IMU_INTERFACES if self.kind == "imu" else FT_INTERFACES
        lines = [f'    <sensor name="{self.name}">']
        lines += [f'      <state_interface name="{i}"/>' for i in interfaces]
        lines += [f'      <param name="frame_id">{self.frame_id}</param>', "    </sensor>"]
        return "\n".join(lines)

    def gazebo_xml(self) -> str:
        lines = [f'  <gazebo reference="{self.reference}">', f'    <sensor name="{self.name}" type="{self.kind}">',
                 "      <always_on>true</always_on>", f"      <update_rate>{fmt(self.update_rate)}</update_rate>"]
        if self.kind == "imu":
            lines.append("      <imu>")
            for quantity, (stddev, bias_mean, bias_stddev) in IMU_AXES_NOISE.items():
                lines.append(f"        <{quantity}>")
                for axis in "xyz":
                    lines.append(f'          <{axis}><noise type="gaussian"><mean>0</mean><stddev>{stddev:g}</stddev>'
                                 f"<bias_mean>{bias_mean:g}</bias_mean><bias_stddev>{bias_stddev:g}</bias_stddev>"
                                 f"</noise></{axis}>")
                lines.append(f"        </{quantity}>")
            lines.append("      </imu>")
        elif self.kind == "contact":   # no ros2_control interfaces: gazebo_ros' bumper plugin publishes it
            side = self.name.removesuffix("_contact")
            lines += [f"      <contact><collision>{self.reference}_collision</collision></contact>",
                      f'      <plugin name="{self.name}_bumper" filename="libgazebo_ros_bumper.so">',
                      f"        <ros><remapping>bumper_states:={side}/contacts</remapping></ros>",
                      "        <frame_name>world</frame_name>", "      </plugin>"]
        else:
            lines += ["      <force_torque>", "        <frame>child</frame>",
                      "        <measure_direction>child_to_parent</measure_direction>", "      </force_torque>"]
        lines += ["    </sensor>", "  </gazebo>\n"]
        return "\n".join(lines)


@dataclass
class Frame:
    """A sensor's link: no geometry (a camera inside a shape would see its inside), a token mass so every
    physics engine accepts it, attached by a fixed joint so TF publishes it."""

    name: str
    mass: float = 0.01
    colour: str = "dark"   # unused: a frame has no visual

    def xml(self) -> str:
        inertia = fmt(1e-6)
        return (f'  <link name="{self.name}">\n    <inertial>\n      <origin xyz="0 0 0" rpy="0 0 0"/>\n'
                f'      <mass value="{fmt(self.mass)}"/>\n'
                f'      <inertia ixx="{inertia}" ixy="0" ixz="0" iyy="{inertia}" iyz="0" izz="{inertia}"/>\n'
                "    </inertial>\n  </link>\n")


@dataclass
class RenderedSensorDecl:
    """A camera or range sensor as Gazebo Classic users declare it, with the gazebo_ros plugin that publishes
    it; topics resolve in the robot's namespace (spawn_entity's -robot_namespace)."""

    name: str
    kind: str          # depth | gpu_ray | ray
    reference: str     # the link it is on
    body: str          # the <camera> or <ray> element
    plugin: str        # the <plugin> element

    def gazebo_xml(self) -> str:
        return (f'  <gazebo reference="{self.reference}">\n    <sensor name="{self.name}" type="{self.kind}">\n'
                f"      <always_on>true</always_on>\n{self.body}{self.plugin}    </sensor>\n  </gazebo>\n")


def _ray_xml(rate: float, horizontal: tuple[int, float, float], vertical: tuple[int, float, float] | None,
             range_min: float, range_max: float, resolution: float) -> str:
    axes = [("horizontal", horizontal)] + ([("vertical", vertical)] if vertical else [])
    lines = [f"      <update_rate>{fmt(rate)}</update_rate>", "      <ray>", "        <scan>"]
    for axis, (samples, low, high) in axes:
        lines += [f"          <{axis}><samples>{samples}</samples><resolution>1</resolution>"
                  f"<min_angle>{fmt(low)}</min_angle><max_angle>{fmt(high)}</max_angle></{axis}>"]
    lines += ["        </scan>", f"        <range><min>{fmt(range_min)}</min><max>{fmt(range_max)}</max>"
              f"<resolution>{fmt(resolution)}</resolution></range>",
              '        <noise><type>gaussian</type><mean>0</mean><stddev>0.01</stddev></noise>', "      </ray>\n"]
    return "\n".join(lines)


def head_sensors() -> tuple[list[tuple[Frame, Joint]], list[RenderedSensorDecl]]:
    """The humanoid's eyes: a head RGB-D camera (optical axis along +x at the stand pose), a 16-ring lidar
    on top of the head and a horizontal laser on the chest; the sensor links sit outside every shape."""
    quarter = math.pi / 2
    frames = [
        (Frame("camera_link"), Joint("camera_joint", "fixed", "head", "camera_link", (0.11, 0, 0.12))),
        (Frame("camera_optical_frame"), Joint("camera_optical_joint", "fixed", "camera_link", "camera_optical_frame",
                                              rpy=(-quarter, 0, -quarter))),
        (Frame("lidar_link"), Joint("lidar_joint", "fixed", "head", "lidar_link", (0, 0, 0.26))),
        (Frame("laser_link"), Joint("laser_joint", "fixed", "torso", "laser_link", (0.12, 0, 0.30))),
    ]
    camera = RenderedSensorDecl(
        "camera", "depth", "camera_link",
        "      <update_rate>30</update_rate>\n      <camera>\n        <horizontal_fov>1.047</horizontal_fov>\n"
        "        <image><width>320</width><height>240</height><format>R8G8B8</format></image>\n"
        "        <clip><near>0.05</near><far>10</far></clip>\n      </camera>\n",
        '      <plugin name="camera_controller" filename="libgazebo_ros_camera.so">\n'
        "        <ros>\n          <remapping>camera/image_raw:=camera/rgb</remapping>\n"
        "          <remapping>camera/depth/image_raw:=camera/depth</remapping>\n        </ros>\n"
        "        <camera_name>camera</camera_name>\n        <frame_name>camera_optical_frame</frame_name>\n"
        "      </plugin>\n")
    step = 2 * math.pi / 900
    lidar = RenderedSensorDecl(
        "lidar", "gpu_ray", "lidar_link",
        _ray_xml(10, (900, -math.pi, math.pi - step), (16, -math.radians(15), math.radians(15)), 0.2, 30, 0.01),
        '      <plugin name="lidar" filename="libgazebo_ros_ray_sensor.so">\n'
        "        <ros><remapping>~/out:=lidar/points</remapping></ros>\n"
        "        <output_type>sensor_msgs/PointCloud2</output_type>\n        <frame_name>lidar_link</frame_name>\n"
        "      </plugin>\n")
    laser = RenderedSensorDecl(
        "laser", "ray", "laser_link",
        _ray_xml(20, (720, -quarter, quarter), None, 0.1, 10, 0.01),
        '      <plugin name="laser" filename="libgazebo_ros_ray_sensor.so">\n'
        "        <ros><remapping>~/out:=scan</remapping></ros>\n"
        "        <output_type>sensor_msgs/LaserScan</output_type>\n        <frame_name>laser_link</frame_name>\n"
        "      </plugin>\n")
    return frames, [camera, lidar, laser]


@dataclass
class Robot:
    name: str
    header: str
    links: list[Link] = field(default_factory=list)
    joints: list[Joint] = field(default_factory=list)
    ros2_control_joints: list[str] = field(default_factory=list)
    sensors: list[SensorDecl] = field(default_factory=list)
    rendered_sensors: list[RenderedSensorDecl] = field(default_factory=list)

    def add(self, link: Link | Frame, joint: Joint | None = None) -> None:
        self.links.append(link)
        if joint is not None:
            self.joints.append(joint)

    def total_mass(self) -> float:
        return sum(link.mass for link in self.links)

    def xml(self) -> str:
        return self.render(lambda joint: joint.xml(), self._control_joint_xml)

    @staticmethod
    def _control_joint_xml(name: str) -> str:
        return (
            f'    <joint name="{name}">\n'
            '      <command_interface name="position"/>\n'
            '      <state_interface name="position"/>\n'
            '      <state_interface name="velocity"/>\n'
            "    </joint>"
        )

    def render(self, joint_xml, control_joint_xml, robot_open: str | None = None, preamble: str = "") -> str:
        """The URDF text, with the joint elements and the <ros2_control> joint entries from the callbacks
        (so the xacro flavour shares everything else)."""
        used = sorted({link.colour for link in self.links})
        out = ['<?xml version="1.0"?>', f"<!-- {self.header.strip()} -->",
               robot_open or f'<robot name="{self.name}">', ""]
        if preamble:
            out.append(preamble)
        out += [f'  <material name="{c}"><color rgba="{fmt(*COLOURS[c])}"/></material>' for c in used]
        out.append("")
        for link in self.links:
            out.append(link.xml())
        for joint in self.joints:
            out.append(joint_xml(joint))
        if self.ros2_control_joints:
            out.append('  <ros2_control name="GazeboSystem" type="system">')
            out.append("    <hardware>\n      <plugin>gazebo_ros2_control/GazeboSystem</plugin>\n    </hardware>")
            for name in self.ros2_control_joints:
                out.append(control_joint_xml(name))
            for sensor in self.sensors:
                if sensor.kind != "contact":
                    out.append(sensor.ros2_control_xml())
            out.append("  </ros2_control>\n")
            for sensor in self.sensors + self.rendered_sensors:
                out.append(sensor.gazebo_xml())
            out.append(
                '  <gazebo>\n    <plugin filename="libgazebo_ros2_control.so" name="gazebo_ros2_control">\n'
                "      <robot_param>robot_description</robot_param>\n"
                "      <robot_param_node>robot_state_publisher</robot_param_node>\n"
                "    </plugin>\n  </gazebo>\n"
            )
        out.append("</robot>\n")
        return "\n".join(out)


def box(x: float, y: float, z: float, at=(0.0, 0.0, 0.0)) -> Shape:
    return Shape("box", (x, y, z), tuple(at))


def cyl(radius: float, length: float, at=(0.0, 0.0, 0.0), rpy=(0.0, 0.0, 0.0)) -> Shape:
    return Shape("cylinder", (radius, length), tuple(at), tuple(rpy))


def sphere(radius: float, at=(0.0, 0.0, 0.0)) -> Shape:
    return Shape("sphere", (radius,), tuple(at))


# --------------------------------------------------------------------------------------------- humanoid
# Geometry (metres) of the main humanoid. Legs hang straight at zero pose; the sole is flat.
HIP_Y, HIP_DROP, HIP_ROLL_DROP = 0.10, 0.10, 0.05
THIGH, SHIN = 0.35, 0.35
ANKLE_TO_SOLE = 0.06
FOOT = (0.22, 0.10, 0.04)
STANDING_PELVIS_HEIGHT = HIP_DROP + HIP_ROLL_DROP + THIGH + SHIN + ANKLE_TO_SOLE


def humanoid() -> Robot:
    r = Robot(
        "humanoid",
        f"22-joint primitive humanoid (floating base, root link pelvis). x forward, y left, z up. "
        f"Standing pelvis height at zero pose (soles flat on z=0): {STANDING_PELVIS_HEIGHT:.3f} m. "
        "Pitch axes are +y, so hip_pitch -0.2, knee +0.4, ankle_pitch -0.2 is a slight squat. "
        "Generated by robots/build_robots.py: edit that, not this file.",
    )
    r.add(Link("pelvis", 8.0, box(0.16, 0.26, 0.12), "dark"))
    r.add(
        Link("torso", 14.0, box(0.18, 0.30, 0.35, at=(0, 0, 0.215)), "blue"),
        Joint("waist_yaw", "revolute", "pelvis", "torso", (0, 0, 0.06), axis=(0, 0, 1),
              lower=-1.0, upper=1.0, effort=150, velocity=6.0, damping=0.5),
    )
    r.add(
        Link("head", 3.0, sphere(0.10, at=(0, 0, 0.12)), "skin"),
        Joint("neck_pitch", "revolute", "torso", "head", (0, 0, 0.40), axis=(0, 1, 0),
              lower=-0.8, upper=0.8, effort=20, velocity=6.0, damping=0.1),
    )
    for side, sign in (("left", 1.0), ("right", -1.0)):
        leg_damping = 1.0
        r.add(
            Link(f"{side}_hip_yaw_link", 1.0, cyl(0.045, 0.05, at=(0, 0, -0.025)), "grey"),
            Joint(f"{side}_hip_yaw", "revolute", "pelvis", f"{side}_hip_yaw_link", (0, sign * HIP_Y, -HIP_DROP + 0.04),
                  axis=(0, 0, 1), lower=-0.8, upper=0.8, effort=150, velocity=10.0, damping=leg_damping),
        )
        # The hip_yaw joint sits 0.04 m below the pelvis origin... plus the 0.06 pelvis half-height,
        # so the hip pitch/roll centre is HIP_DROP + HIP_ROLL_DROP below the pelvis origin.
        r.add(
            Link(f"{side}_hip_roll_link", 1.0, cyl(0.045, 0.08, at=(0, 0, 0), rpy=(0, math.pi / 2, 0)), "grey"),
            Joint(f"{side}_hip_roll", "revolute", f"{side}_hip_yaw_link", f"{side}_hip_roll_link",
                  (0, 0, -HIP_ROLL_DROP - 0.04), axis=(1, 0, 0), lower=-0.5, upper=0.5, effort=250,
                  velocity=10.0, damping=leg_damping),
        )
        r.add(
            Link(f"{side}_thigh", 5.0, cyl(0.055, THIGH - 0.04, at=(0, 0, -THIGH / 2)), "white"),
            Joint(f"{side}_hip_pitch", "revolute", f"{side}_hip_roll_link", f"{side}_thigh", (0, 0, 0),
                  axis=(0, 1, 0), lower=-2.0, upper=0.7, effort=250, velocity=10.0, damping=leg_damping),
        )
        r.add(
            Link(f"{side}_shin", 3.0, cyl(0.045, SHIN - 0.04, at=(0, 0, -SHIN / 2)), "white"),
            Joint(f"{side}_knee", "revolute", f"{side}_thigh", f"{side}_shin", (0, 0, -THIGH),
                  axis=(0, 1, 0), lower=-0.05, upper=2.4, effort=300, velocity=10.0, damping=leg_damping),
        )
        r.add(
            Link(f"{side}_ankle_pitch_link", 0.5, sphere(0.035), "grey"),
            Joint(f"{side}_ankle_pitch", "revolute", f"{side}_shin", f"{side}_ankle_pitch_link", (0, 0, -SHIN),
                  axis=(0, 1, 0), lower=-0.9, upper=0.9, effort=150, velocity=10.0, damping=leg_damping),
        )
        r.add(
            Link(f"{side}_foot", 1.2, box(*FOOT, at=(0.03, 0, -ANKLE_TO_SOLE + FOOT[2] / 2)), "orange"),
            Joint(f"{side}_ankle_roll", "revolute", f"{side}_ankle_pitch_link", f"{side}_foot", (0, 0, 0),
                  axis=(1, 0, 0), lower=-0.4, upper=0.4, effort=150, velocity=10.0, damping=leg_damping),
        )
    for side, sign in (("left", 1.0), ("right", -1.0)):
        r.add(
            Link(f"{side}_shoulder_pitch_link", 0.5, sphere(0.045), "grey"),
            Joint(f"{side}_shoulder_pitch", "revolute", "torso", f"{side}_shoulder_pitch_link",
                  (0, sign * 0.21, 0.33), axis=(0, 1, 0), lower=-3.0, upper=1.2, effort=60, velocity=8.0,
                  damping=0.2),
        )
        r.add(
            Link(f"{side}_shoulder_roll_link", 0.5, cyl(0.04, 0.06, at=(0, 0, -0.03)), "grey"),
            Joint(f"{side}_shoulder_roll", "revolute", f"{side}_shoulder_pitch_link", f"{side}_shoulder_roll_link",
                  (0, 0, 0), axis=(1, 0, 0), lower=-0.5 if sign > 0 else -2.5, upper=2.5 if sign > 0 else 0.5,
                  effort=60, velocity=8.0, damping=0.2),
        )
        r.add(
            Link(f"{side}_upper_arm", 2.0, cyl(0.04, 0.22, at=(0, 0, -0.14)), "white"),
            Joint(f"{side}_shoulder_yaw", "revolute", f"{side}_shoulder_roll_link", f"{side}_upper_arm",
                  (0, 0, -0.06), axis=(0, 0, 1), lower=-1.5, upper=1.5, effort=40, velocity=8.0, damping=0.2),
        )
        r.add(
            Link(f"{side}_forearm", 1.5, cyl(0.035, 0.25, at=(0, 0, -0.125)), "white"),
            Joint(f"{side}_elbow", "revolute", f"{side}_upper_arm", f"{side}_forearm", (0, 0, -0.28),
                  axis=(0, 1, 0), lower=-2.5, upper=0.5, effort=40, velocity=8.0, damping=0.2),
        )
    r.ros2_control_joints = [j.name for j in r.joints if j.kind != "fixed"]
    # a pelvis IMU and a force/torque sensor in each ankle, measuring the load between the leg and the foot
    r.sensors = [SensorDecl("imu_sensor", "imu", "pelvis", "pelvis")]
    r.sensors += [SensorDecl(f"{side}_foot_ft", "force_torque", f"{side}_ankle_roll", f"{side}_foot")
                  for side in ("left", "right")]
    r.sensors += [SensorDecl(f"{side}_foot_contact", "contact", f"{side}_foot", "world", update_rate=100)
                  for side in ("left", "right")]
    frames, r.rendered_sensors = head_sensors()
    for frame, joint in frames:
        r.add(frame, joint)
    return r


# Joints the 20-DOF variant locks (fixed joints): 12 leg + 8 arm joints stay movable.
LOCKED_IN_20_DOF = ("waist_yaw", "neck_pitch")


def humanoid_xacro() -> str:
    """``humanoid.urdf.xacro``: the same humanoid with xacro arguments for variants.

    With no arguments it expands to the robot of ``humanoid.urdf`` (a test checks this). Seed 000's
    "20-DOF humanoid" exercise is ``dof:=20 velocity_limit:=2 effort_limit:=50``: waist and neck locked,
    every remaining joint limited to 2 rad/s and 50 Nm in its <limit> and in the <ros2_control> block
    (velocity and effort command interfaces with min/max, as ros2_control reads limits from there)."""
    r = humanoid()
    r.header = (
        "The humanoid of humanoid.urdf as xacro, with arguments for variants: dof (22, or 20 with "
        "waist_yaw and neck_pitch locked), velocity_limit (rad/s) and effort_limit (Nm) for every joint "
        "(0: each joint's own). Expand with `zenroid xacro robots/humanoid.urdf.xacro dof:=20 "
        "velocity_limit:=2 effort_limit:=50`. Generated by robots/build_robots.py: edit that, not this file."
    )
    locked = "${dof == 20}"
    preamble = "\n".join([
        '  <xacro:arg name="dof" default="22"/>',
        '  <xacro:arg name="velocity_limit" default="0"/>',
        '  <xacro:arg name="effort_limit" default="0"/>',
        '  <xacro:property name="dof" value="$(arg dof)"/>',
        '  <xacro:property name="velocity_limit" value="$(arg velocity_limit)"/>',
        '  <xacro:property name="effort_limit" value="$(arg effort_limit)"/>',
        '  <xacro:if value="${dof not in (20, 22)}">${xacro.fatal(\'dof must be 22 or 20, got \' + str(dof))}'
        "</xacro:if>",
        '  <xacro:if value="${velocity_limit &lt; 0 or effort_limit &lt; 0}">'
        "${xacro.fatal('velocity_limit and effort_limit must not be negative')}</xacro:if>",
        "",
        "  <!-- One joint of the <ros2_control> block; the limits, when given, as min/max of a velocity and",
        "       an effort command interface (position control only: the controllers claim 'position'). -->",
        '  <xacro:macro name="control_joint" params="joint">',
        '    <joint name="${joint}">',
        '      <command_interface name="position"/>',
        '      <xacro:if value="${velocity_limit > 0}">',
        '        <command_interface name="velocity">',
        '          <param name="min">${-velocity_limit}</param>',
        '          <param name="max">${velocity_limit}</param>',
        "        </command_interface>",
        "      </xacro:if>",
        '      <xacro:if value="${effort_limit > 0}">',
        '        <command_interface name="effort">',
        '          <param name="min">${-effort_limit}</param>',
        '          <param name="max">${effort_limit}</param>',
        "        </command_interface>",
        "      </xacro:if>",
        '      <state_interface name="position"/>',
        '      <state_interface name="velocity"/>',
        "    </joint>",
        "  </xacro:macro>",
        "",
    ])

    def joint_xml(joint: Joint) -> str:
        if joint.kind == "fixed":
            return joint.xml()
        text = joint.xml(effort=f"${{effort_limit if effort_limit > 0 else {fmt(joint.effort)}}}",
                         velocity=f"${{velocity_limit if velocity_limit > 0 else {fmt(joint.velocity)}}}")
        if joint.name not in LOCKED_IN_20_DOF:
            return text
        fixed = Joint(joint.name, "fixed", joint.parent, joint.child, joint.xyz, joint.rpy).xml()
        return (f'  <xacro:if value="{locked}">\n{fixed}  </xacro:if>\n'
                f'  <xacro:unless value="{locked}">\n{text}  </xacro:unless>\n')

    def control_joint_xml(name: str) -> str:
        entry = f'    <xacro:control_joint joint="{name}"/>'
        if name in LOCKED_IN_20_DOF:
            return f'    <xacro:unless value="{locked}">\n  {entry}\n    </xacro:unless>'
        return entry

    robot_open = '<robot xmlns:xacro="http://www.ros.org/wiki/xacro" name="humanoid">'
    return r.render(joint_xml, control_joint_xml, robot_open, preamble)


def humanoid_20dof_xacro() -> str:
    """Seed 000's exercise "a 20-DOF humanoid, position control, 2 rad/s, 50 Nm": xacro arguments on
    ``humanoid.urdf.xacro`` (an argument given here is its default; the command line still overrides)."""
    return (
        '<?xml version="1.0"?>\n'
        "<!-- The 20-DOF humanoid of seed 000's controller-setup exercise: humanoid.urdf.xacro with waist and\n"
        "     neck locked, 2 rad/s and 50 Nm on every joint (in <limit> and in the <ros2_control> block).\n"
        "     Generated by robots/build_robots.py. -->\n"
        '<robot xmlns:xacro="http://www.ros.org/wiki/xacro" name="humanoid_20dof">\n'
        '  <xacro:arg name="dof" default="20"/>\n'
        '  <xacro:arg name="velocity_limit" default="2"/>\n'
        '  <xacro:arg name="effort_limit" default="50"/>\n'
        '  <xacro:include filename="humanoid.urdf.xacro"/>\n'
        "</robot>\n"
    )


XACRO_BUILDERS = {"humanoid.urdf.xacro": humanoid_xacro, "humanoid_20dof.urdf.xacro": humanoid_20dof_xacro}


# ------------------------------------------------------------------------------ Module 2 lab upper body
def humanoid_simplified() -> Robot:
    """Module 2 lab: torso base link with two planar arms (all joint axes +z).

    The tutorial's analytic FK lays each arm along x from the shoulder (0.15, ±0.1, 0.15) with an
    upper arm of 0.25 m and a forearm of 0.2 m; the joint origins here follow that FK so the URDF and
    the tutorial's formula agree (its listed URDF put the offsets along z, which contradicts its FK).
    """
    r = Robot(
        "humanoid_simplified",
        "Module 2 lab upper body: fixed base_link (torso), two 3-joint planar arms, joint axes +z. "
        "Generated by robots/build_robots.py.",
    )
    along_x = (0.0, math.pi / 2, 0.0)
    r.add(Link("base_link", 5.0, box(0.3, 0.2, 0.4), "white"))
    for side, sign in (("left", 1.0), ("right", -1.0)):
        r.add(
            Link(f"{side}_upper_arm", 1.0, cyl(0.04, 0.25, at=(0.125, 0, 0), rpy=along_x), "blue"),
            Joint(f"{side}_shoulder_joint", "revolute", "base_link", f"{side}_upper_arm", (0.15, sign * 0.1, 0.15),
                  axis=(0, 0, 1), lower=-3.14, upper=3.14, effort=20, velocity=2.0),
        )
        r.add(
            Link(f"{side}_forearm", 0.6, cyl(0.035, 0.2, at=(0.1, 0, 0), rpy=along_x), "blue"),
            Joint(f"{side}_elbow_joint", "revolute", f"{side}_upper_arm", f"{side}_forearm", (0.25, 0, 0),
                  axis=(0, 0, 1), lower=0.0, upper=3.14, effort=10, velocity=2.0),
        )
        r.add(
            Link(f"{side}_hand", 0.2, box(0.05, 0.08, 0.03, at=(0.025, 0, 0)), "skin"),
            Joint(f"{side}_wrist_joint", "revolute", f"{side}_forearm", f"{side}_hand", (0.2, 0, 0),
                  axis=(0, 0, 1), lower=-1.57, upper=1.57, effort=5, velocity=3.0),
        )
    r.ros2_control_joints = [j.name for j in r.joints]
    return r


def simple_2dof_arm() -> Robot:
    """Module 2 URDF example: base box, shoulder and elbow about +z, links 0.3 m and 0.25 m along x."""
    r = Robot(
        "simple_2dof_arm",
        "Module 2 example 2-DOF planar arm (fixed base, joint axes +z). Generated by robots/build_robots.py.",
    )
    along_x = (0.0, math.pi / 2, 0.0)
    r.add(Link("base_link", 1.0, box(0.2, 0.2, 0.1), "dark"))
    r.add(
        Link("upper_arm", 0.5, cyl(0.05, 0.3, at=(0.15, 0, 0), rpy=along_x), "blue"),
        Joint("shoulder_joint", "revolute", "base_link", "upper_arm", (0, 0, 0.1), axis=(0, 0, 1),
              lower=-3.14, upper=3.14, effort=10, velocity=1.0, damping=0.05),
    )
    r.add(
        Link("forearm", 0.3, cyl(0.04, 0.25, at=(0.125, 0, 0), rpy=along_x), "orange"),
        Joint("elbow_joint", "revolute", "upper_arm", "forearm", (0.3, 0, 0), axis=(0, 0, 1),
              lower=-3.14, upper=3.14, effort=5, velocity=1.0, damping=0.05),
    )
    r.ros2_control_joints = [j.name for j in r.joints]
    return r


# --------------------------------------------------------------------------------------- Lab 2.3 robot
def lab_robot() -> Robot:
    """Lab 2.3: a torso on a fixed stand with one pitch joint per limb (arms wave ±1 rad, legs ±0.5)."""
    r = Robot(
        "lab_robot",
        "Lab 2.3 robot: torso on a fixed stand (base_link), one revolute joint per limb, axes +y. "
        "Generated by robots/build_robots.py.",
    )
    r.add(Link("base_link", 10.0, box(0.4, 0.4, 0.05, at=(0, 0, 0.025)), "dark"))
    r.add(
        Link("stand", 2.0, cyl(0.03, 0.6, at=(0, 0, 0.3)), "grey"),
        Joint("stand_joint", "fixed", "base_link", "stand", (0, 0, 0.05)),
    )
    r.add(
        Link("torso", 6.0, box(0.2, 0.3, 0.4, at=(0, 0, 0.2)), "blue"),
        Joint("torso_joint", "fixed", "stand", "torso", (0, 0, 0.6)),
    )
    for side, sign in (("left", 1.0), ("right", -1.0)):
        r.add(
            Link(f"{side}_arm", 1.0, cyl(0.03, 0.35, at=(0, 0, -0.175)), "orange"),
            Joint(f"{side}_arm_joint", "revolute", "torso", f"{side}_arm", (0, sign * 0.19, 0.36),
                  axis=(0, 1, 0), lower=-1.57, upper=1.57, effort=30, velocity=3.0, damping=0.1),
        )
        r.add(
            Link(f"{side}_leg", 2.0, cyl(0.04, 0.45, at=(0, 0, -0.225)), "white"),
            Joint(f"{side}_leg_joint", "revolute", "torso", f"{side}_leg", (0, sign * 0.08, -0.01),
                  axis=(0, 1, 0), lower=-1.0, upper=1.0, effort=60, velocity=3.0, damping=0.1),
        )
    r.ros2_control_joints = [j.name for j in r.joints if j.kind != "fixed"]
    return r


# ------------------------------------------------------------------------------------------ Atlas-style
def atlas() -> Robot:
    """28-joint Atlas-style robot with the DRC joint names (geometry and masses close to Atlas v3).

    The joint-animation tutorial plays every joint between -0.5 and +0.5 rad, so every range covers that.
    """
    r = Robot(
        "atlas",
        "28-joint Atlas-style robot (DRC joint names, floating base pelvis, primitive shapes). "
        "Generated by robots/build_robots.py.",
    )
    r.add(Link("pelvis", 14.2, box(0.2, 0.3, 0.15, at=(0.0, 0, 0.0)), "dark"))
    r.add(Link("ltorso", 2.3, box(0.12, 0.15, 0.1, at=(0, 0, 0.05)), "grey"),
          Joint("back_lbz", "revolute", "pelvis", "ltorso", (-0.0125, 0, 0.075), axis=(0, 0, 1),
                lower=-0.66, upper=0.66, effort=124, velocity=12))
    r.add(Link("mtorso", 0.8, cyl(0.05, 0.08, at=(0, 0, 0.0), rpy=(math.pi / 2, 0, 0)), "grey"),
          Joint("back_mby", "revolute", "ltorso", "mtorso", (0, 0, 0.162), axis=(0, 1, 0),
                lower=-0.6, upper=0.6, effort=206, velocity=9))
    r.add(Link("utorso", 25.0, box(0.3, 0.45, 0.45, at=(0.02, 0, 0.25)), "blue"),
          Joint("back_ubx", "revolute", "mtorso", "utorso", (0, 0, 0.05), axis=(1, 0, 0),
                lower=-0.79, upper=0.79, effort=94, velocity=12))
    r.add(Link("head", 1.4, sphere(0.1, at=(0.05, 0, 0.08)), "skin"),
          Joint("neck_ay", "revolute", "utorso", "head", (0.17, 0, 0.55), axis=(0, 1, 0),
                lower=-0.6, upper=1.14, effort=5, velocity=6.28))
    for p, sign in (("l", 1.0), ("r", -1.0)):
        r.add(Link(f"{p}_uglut", 0.5, cyl(0.04, 0.06), "grey"),
              Joint(f"{p}_leg_uhz", "revolute", "pelvis", f"{p}_uglut", (0, sign * 0.089, -0.075), axis=(0, 0, 1),
                    lower=-0.78, upper=0.78, effort=110, velocity=12))
        r.add(Link(f"{p}_lglut", 0.7, cyl(0.04, 0.1, at=(0.0, 0, -0.03), rpy=(0, math.pi / 2, 0)), "grey"),
              Joint(f"{p}_leg_mhx", "revolute", f"{p}_uglut", f"{p}_lglut", (0, 0, -0.02), axis=(1, 0, 0),
                    lower=-0.5, upper=0.5, effort=180, velocity=12))
        r.add(Link(f"{p}_uleg", 7.3, cyl(0.07, 0.3, at=(0, 0, -0.19)), "white"),
              Joint(f"{p}_leg_lhy", "revolute", f"{p}_lglut", f"{p}_uleg", (0.05, sign * 0.0225, -0.066),
                    axis=(0, 1, 0), lower=-1.75, upper=0.6, effort=260, velocity=12))
        r.add(Link(f"{p}_lleg", 4.4, cyl(0.055, 0.34, at=(0.0, 0, -0.19)), "white"),
              Joint(f"{p}_leg_kny", "revolute", f"{p}_uleg", f"{p}_lleg", (-0.05, 0, -0.374), axis=(0, 1, 0),
                    lower=-0.6, upper=2.45, effort=220, velocity=12))
        r.add(Link(f"{p}_talus", 0.13, sphere(0.03), "grey"),
              Joint(f"{p}_leg_uay", "revolute", f"{p}_lleg", f"{p}_talus", (0, 0, -0.422), axis=(0, 1, 0),
                    lower=-1.0, upper=0.7, effort=220, velocity=12))
        r.add(Link(f"{p}_foot", 2.05, box(0.26, 0.13, 0.05, at=(0.04, 0, -0.056)), "orange"),
              Joint(f"{p}_leg_lax", "revolute", f"{p}_talus", f"{p}_foot", (0, 0, 0), axis=(1, 0, 0),
                    lower=-0.6, upper=0.6, effort=90, velocity=12))
    for p, sign in (("l", 1.0), ("r", -1.0)):
        # usy is tilted 30 degrees out of the horizontal, as on the real robot: a non-axis-aligned axis.
        r.add(Link(f"{p}_clav", 3.45, cyl(0.05, 0.14, at=(0, sign * 0.04, 0.02), rpy=(math.pi / 2, 0, 0)), "grey"),
              Joint(f"{p}_arm_usy", "revolute", "utorso", f"{p}_clav", (0.024, sign * 0.221, 0.289),
                    axis=(0, 0.5, sign * 0.866025), lower=-1.9, upper=1.9, effort=212, velocity=12))
        r.add(Link(f"{p}_scap", 3.0, cyl(0.05, 0.12, at=(0, sign * 0.09, 0), rpy=(math.pi / 2, 0, 0)), "grey"),
              Joint(f"{p}_arm_shx", "revolute", f"{p}_clav", f"{p}_scap", (0, sign * 0.075, 0.036), axis=(1, 0, 0),
                    lower=-1.57, upper=1.57, effort=170, velocity=12))
        r.add(Link(f"{p}_uarm", 3.4, cyl(0.045, 0.1, at=(0, sign * 0.06, 0), rpy=(math.pi / 2, 0, 0)), "white"),
              Joint(f"{p}_arm_ely", "revolute", f"{p}_scap", f"{p}_uarm", (0, sign * 0.185, 0), axis=(0, 1, 0),
                    lower=-0.6, upper=3.14, effort=114, velocity=12))
        r.add(Link(f"{p}_larm", 2.5, cyl(0.045, 0.14, at=(0, sign * 0.09, 0), rpy=(math.pi / 2, 0, 0)), "white"),
              Joint(f"{p}_arm_elx", "revolute", f"{p}_uarm", f"{p}_larm", (0, sign * 0.121, 0.013), axis=(1, 0, 0),
                    lower=-2.35, upper=2.35, effort=114, velocity=12))
        r.add(Link(f"{p}_farm", 3.4, cyl(0.04, 0.1, at=(0, sign * 0.06, 0), rpy=(math.pi / 2, 0, 0)), "white"),
              Joint(f"{p}_arm_uwy", "revolute", f"{p}_larm", f"{p}_farm", (0, sign * 0.188, -0.013), axis=(0, 1, 0),
                    lower=-1.57, upper=3.14, effort=114, velocity=12))
        r.add(Link(f"{p}_hand", 2.5, box(0.08, 0.1, 0.1, at=(0, sign * 0.06, 0)), "skin"),
              Joint(f"{p}_arm_mwx", "revolute", f"{p}_farm", f"{p}_hand", (0, sign * 0.058, 0), axis=(1, 0, 0),
                    lower=-1.18, upper=1.18, effort=60, velocity=12))
    r.ros2_control_joints = [j.name for j in r.joints]
    r.sensors = [SensorDecl("imu_sensor", "imu", "pelvis", "pelvis")]
    r.sensors += [SensorDecl(f"{side}_foot_ft", "force_torque", f"{p}_leg_lax", f"{p}_foot")
                  for side, p in (("left", "l"), ("right", "r"))]
    r.sensors += [SensorDecl(f"{side}_foot_contact", "contact", f"{p}_foot", "world", update_rate=100)
                  for side, p in (("left", "l"), ("right", "r"))]
    return r


BUILDERS = {
    "humanoid": humanoid,
    "humanoid_simplified": humanoid_simplified,
    "simple_2dof_arm": simple_2dof_arm,
    "lab_robot": lab_robot,
    "atlas": atlas,
}


def main() -> None:
    for name, build in BUILDERS.items():
        robot = build()
        (HERE / f"{name}.urdf").write_text(robot.xml())
        print(f"{name}.urdf: {len(robot.links)} links, {len(robot.joints)} joints, {robot.total_mass():.1f} kg")
    for file, build_text in XACRO_BUILDERS.items():
        (HERE / file).write_text(build_text())
        print(f"{file}: xacro")


if __name__ == "__main__":
    main()
