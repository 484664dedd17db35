"""A ROS 2 node that asks a photomodel cell service where a garment is and publishes the pose.

It keeps the latest image of each hand camera (``sensor_msgs/CompressedImage``, PNG or JPEG as
``image_transport`` sends them; the latest two make a pair while the table is still), and on
each call of its ``~/locate`` service (``std_srvs/Trigger``) posts the pair to ``/locate`` and
publishes the answer's ``pose_stamped`` as ``geometry_msgs/PoseStamped`` on ``garment_pose``
(stamped when the service answered; frame ``cam1`` unless the ``frame_id`` parameter names
the right camera's frame in your tf tree).

    python3 ros2_forward.py --ros-args -p url:=http://127.0.0.1:8080 -p model:=No.3 \\
        -r right/image_raw/compressed:=/cam1/image_raw/compressed \\
        -r left/image_raw/compressed:=/cam2/image_raw/compressed
    ros2 service call /photomodel_locate/locate std_srvs/srv/Trigger

Keep ``locate_client.py`` beside it (the HTTP call). Nothing ROS is imported until
:func:`main`, so :func:`pose_fields` runs (and is tested) without ROS.
"""

from __future__ import annotations

import math
from typing import Any


def stamp_time(stamp_s: float) -> tuple[int, int]:
    """Unix seconds -> ``builtin_interfaces/Time``'s ``(sec, nanosec)``, nanosec < 1e9."""
    sec = math.floor(stamp_s)
    nanosec = round((stamp_s - sec) * 1e9)      # the subtraction is exact, the product not
    return (sec + 1, 0) if nanosec == 1_000_000_000 else (sec, nanosec)


def pose_fields(pose_stamped: dict[str, Any], frame_id: str | None = None) -> dict[str, Any]:
    """The service's ``pose_stamped`` (metres, xyzw, unix seconds) -> the fields of a
    ``geometry_msgs/PoseStamped`` (``rosidl_runtime_py.set_message_fields`` takes them):
    the stamp as ``sec``/``nanosec``, the quaternion normalised, ``frame_id`` replaced when
    given (the service says ``cam1``: the rig's right camera)."""
    header, pose = pose_stamped["header"], pose_stamped["pose"]
    q = pose["orientation"]
    norm = math.sqrt(sum(float(q[k]) ** 2 for k in "xyzw"))
    if not math.isfinite(norm) or norm == 0.0:
        raise ValueError(f"pose_stamped: the orientation {q} is not a rotation")
    sec, nanosec = stamp_time(float(header["stamp"]))
    return {"header": {"frame_id": frame_id or header["frame_id"],
                       "stamp": {"sec": sec, "nanosec": nanosec}},
            "pose": {"position": {k: float(pose["position"][k]) for k in "xyz"},
                     "orientation": {k: float(q[k]) / norm for k in "xyzw"}}}


def main() -> None:
    import rclpy
    from geometry_msgs.msg import PoseStamped
    from locate_client import locate  # beside this file
    from rosidl_runtime_py.set_message import set_message_fields
    from sensor_msgs.msg import CompressedImage
    from std_srvs.srv import Trigger

    rclpy.init()
    node = rclpy.create_node("photomodel_locate")
    url = node.declare_parameter("url", "http://127.0.0.1:8080").value
    model = node.declare_parameter("model", "No.3").value
    frame_id = node.declare_parameter("frame_id", "").value  # "": the answer's (cam1)
    publisher = node.create_publisher(PoseStamped, "garment_pose", 10)
    latest: dict[str, CompressedImage] = {}
    for side in ("right", "left"):
        node.create_subscription(CompressedImage, f"{side}/image_raw/compressed",
                                 lambda msg, side=side: latest.__setitem__(side, msg), 1)

    def on_locate(request: Trigger.Request, response: Trigger.Response) -> Trigger.Response:
        if len(latest) < 2:
            response.message = "no image pair yet"
            return response
        try:
            answer = locate(url, model, bytes(latest["right"].data), bytes(latest["left"].data))
        except (RuntimeError, OSError, ValueError) as err:   # refused, unreachable, not JSON
            response.message = f"service: {err}"
            return response
        response.success = bool(answer["found"])
        response.message = f"{model}: found={answer['found']} score={answer['score']}"
        if answer["found"]:
            msg = PoseStamped()
            set_message_fields(msg, pose_fields(answer["pose_stamped"], frame_id or None))
            publisher.publish(msg)
        return response

    node.create_service(Trigger, "~/locate", on_locate)
    try:
        rclpy.spin(node)
    except KeyboardInterrupt:
        pass
    finally:
        node.destroy_node()
        rclpy.try_shutdown()


if __name__ == "__main__":
    main()
