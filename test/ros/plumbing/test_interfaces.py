"""Message classes found by their type names, with no rosidl_runtime_py."""

from __future__ import annotations

import pytest
from geometry_msgs.msg import Vector3
from swazure_interfaces.msg import Measurements
from swazure_interfaces.srv import ComputePose

from swazure_ros.core.errors import SwazureError
from swazure_ros.ros.plumbing.interfaces import message_class


def test_a_type_name_gives_its_class_in_each_spelling():
    assert message_class("geometry_msgs/msg/Vector3") is Vector3
    # get_fields_and_field_types names nested messages without the "msg" part.
    assert message_class("geometry_msgs/Vector3") is Vector3
    assert message_class("swazure_interfaces/msg/Measurements") is Measurements
    assert message_class("swazure_interfaces/srv/ComputePose") is ComputePose


@pytest.mark.parametrize(
    ("type_name", "says"),
    [
        ("no_such_pkg/msg/Nope", "no interface package 'no_such_pkg'"),
        ("geometry_msgs/msg/Nope", "geometry_msgs has no msg Nope"),
        # A submodule of the package is not a message.
        ("geometry_msgs/msg/_vector3", "no msg _vector3"),
        ("Vector3", "pkg/msg/Type"),
        ("geometry_msgs/msg/", "pkg/msg/Type"),
        ("geometry_msgs/things/Vector3", "pkg/msg/Type"),
        ("../msg/Vector3", "pkg/msg/Type"),
        ("os.path/msg/join", "pkg/msg/Type"),
    ],
)
def test_an_unknown_or_malformed_type_name_is_one_clear_error(type_name, says):
    with pytest.raises(SwazureError) as raised:
        message_class(type_name)
    assert says in str(raised.value), raised.value
