"""Bring up a swarm from a swarm file, as `swazure spawn FILE` does.

    ros2 launch swazure_ros swarm.launch.py                  # the example torus, packed
    ros2 launch swazure_ros swarm.launch.py swarm:=trio mode:=per_fls
    ros2 launch swazure_ros swarm.launch.py swarm:=my/swarm.yaml discovery_server:=127.0.0.1:11811

Arguments:

- ``swarm``: a swarm file (docs/swarm.md, "A swarm in one file"), or the name of an
  installed example (``torus``, the default; ``trio``, ``grid25``, ``dragon``,
  ``racecar``: the package's config/swarms/), found from any folder; read by the
  library (``app.config``), never by the command line's modules;
- ``mode``: ``packed`` (the default) runs ``swazure spawn`` on the file, its
  FLS nodes many to a process, each with parameter services (``ros2 param``);
  ``per_fls`` runs every FLS in a process of its own (``ros2 run swazure_ros
  fls``), beside the simulator (``world``: the world node and the FLSs'
  simulated cameras) and the ``coordinator``, as real FLS hardware would, each
  with the file's ``params:`` (else config/swarm.yaml) and on its ``domain_id``;
- ``discovery_server``: ``IP[:PORT],...``: discover through these Fast DDS
  Discovery Servers (those at an address of this machine are started here),
  as ``swazure spawn --discovery-server`` does (docs/swarm.md).

The swarm's processes share a fresh key and swarm instance (docs/security.md) made here;
the key's temporary folder is removed when the launch ends, however its processes ended.
Ctrl-C stops the whole swarm: each process leaves without telling its peers, who leave too
(docs/swarm.md, "Stopping").
"""

import atexit
import os
import secrets
import shutil
import sys
import tempfile
from pathlib import Path

import yaml
from launch.actions import DeclareLaunchArgument, ExecuteProcess, OpaqueFunction
from launch.substitutions import LaunchConfiguration
from launch_ros.actions import Node

from launch import LaunchDescription
from swazure_ros.app.config import config_from_file, load_swarm_file
from swazure_ros.app.discovery_server import (
    client_environment,
    is_local,
    parse_servers,
    server_command,
    server_environment,
)
from swazure_ros.app.per_fls import FLS_ENVIRONMENT, STOP_GRACE, parameter_file
from swazure_ros.files.swarm_file import example_swarms, find_swarm_file
from swazure_ros.ros.nodes import world_node
from swazure_ros.ros.plumbing.process import SWARM_STOP_VARIABLE
from swazure_ros.ros.plumbing.startup import description_parameters, startup_arguments
from swazure_ros.ros.programs import coordinator_program, fls_program
from swazure_ros.ros.security.auth import INSTANCE_BYTES
from swazure_ros.ros.security.keys import new_key, write_key

PACKAGE = "swazure_ros"


def _servers(servers: tuple) -> list:
    """The discovery servers of this machine, as processes of the launch."""
    return [
        ExecuteProcess(
            cmd=server_command(index, server),
            name=f"discovery_server_{index}",
            additional_env={"LD_LIBRARY_PATH": server_environment()["LD_LIBRARY_PATH"]},
            output="screen",
        )
        for index, server in enumerate(servers)
        if is_local(server.host)
    ]


def _packed(path: Path, servers: tuple) -> list:
    command = [sys.executable, "-m", "swazure_ros.cli.main", "spawn", str(path)]
    if servers:
        command += ["--discovery-server", ",".join(str(server) for server in servers)]
    return [
        ExecuteProcess(
            cmd=[*command, "--parameter-services", "--quiet"],
            name="swazure_spawn",
            output="screen",
        )
    ]


def _per_fls(path: Path, servers: tuple) -> list:
    # The swarm file's swarm, as swazure spawn FILE brings it up (app.config).
    config = config_from_file(load_swarm_file(path))
    folder = Path(tempfile.mkdtemp(prefix="swazure-launch-"))
    # When this launch ends (its last act, after every process has ended, whatever their
    # codes): each process read the key, and a resampled cloud, at its start.
    atexit.register(shutil.rmtree, folder, ignore_errors=True)
    # The file's resample: (its cloud at another size) made once, here, read by every process.
    description, namespace = config.world.written(folder), config.namespace
    key_file = folder / "swarm.key"
    write_key(key_file, new_key())
    shared = {
        **description_parameters(description),
        "namespace": namespace,
        "key_file": str(key_file),
        # This swarm's life, inside every tag: given here, no process waits for the world's.
        "swarm_instance": secrets.token_hex(INSTANCE_BYTES),
    }
    ids = description.fls_ids().tolist()
    # Plain clients of the servers: the coordinator counts matched endpoints, and the
    # graph's node names reach every participant. Ctrl-C's SIGINT stops the whole swarm.
    swarm_env = {
        **(client_environment(servers, super_client=False) if servers else {}),
        SWARM_STOP_VARIABLE: "1",
    }
    if config.domain_id is not None:  # the file's domain_id, as swazure spawn takes it
        swarm_env["ROS_DOMAIN_ID"] = str(config.domain_id)
    # ros2 launch would send SIGTERM after 5 s: a process given longer says where it hung
    # (process.STOP_LIMIT) rather than die of a signal, as under swazure spawn.
    stopping = {"sigterm_timeout": str(STOP_GRACE)}
    # One parameter file for every FLS, in the launch's folder (removed with it): launch_ros
    # would write one per FLS of a parameters dict into /tmp, and leave them there.
    parameters = folder / "parameters.yaml"
    content = parameter_file(namespace, config.parameters, config.fls_parameters)
    parameters.write_text(yaml.safe_dump(content, sort_keys=False))
    actions = [
        # No name= for a program that names its nodes itself: a node-name remap
        # would name every node of its process alike.
        Node(
            package=PACKAGE,
            executable="world",
            # The output's label: the node's name (launch appends its process count), so
            # that [fls_7-9] is FLS 7, not the ninth process named fls.
            exec_name="world",
            namespace=namespace,
            # The file's params: (else config/swarm.yaml) to every process, as swazure spawn.
            parameters=[config.params_file],
            arguments=startup_arguments(shared, world_node.STARTUP),
            additional_env=swarm_env,
            output="screen",
            **stopping,
        ),
        Node(
            package=PACKAGE,
            executable="coordinator",
            exec_name="coordinator",
            name="coordinator",
            namespace=namespace,
            parameters=[config.params_file],  # its round_timeout
            arguments=startup_arguments(
                {**shared, "hosts": len(ids)}, coordinator_program.STARTUP
            ),
            additional_env=swarm_env,
            output="screen",
            **stopping,
        ),
    ]
    actions += [
        Node(
            package=PACKAGE,
            executable="fls",
            exec_name=f"fls_{fls_id}",
            namespace=namespace,
            arguments=startup_arguments({**shared, "fls_id": fls_id}, fls_program.STARTUP),
            # The ROS parameter file first: the swarm file's own parameters win over it.
            parameters=[config.params_file, str(parameters)],
            # As swazure spawn --per-fls starts them; the user's environment wins.
            additional_env={
                **{k: v for k, v in FLS_ENVIRONMENT.items() if k not in os.environ},
                **swarm_env,
            },
            output="screen",
            **stopping,
        )
        for fls_id in ids
    ]
    return actions


def _swarm(context):
    try:
        path = find_swarm_file(LaunchConfiguration("swarm").perform(context)).resolve()
    except ValueError as err:
        raise RuntimeError(f"swarm:={err}") from None
    named = LaunchConfiguration("discovery_server").perform(context)
    servers = parse_servers(named) if named else ()
    if LaunchConfiguration("mode").perform(context) == "per_fls":
        return [*_servers(servers), *_per_fls(path, servers)]
    return _packed(path, servers)  # swazure spawn starts this machine's servers itself


def generate_launch_description():
    return LaunchDescription(
        [
            DeclareLaunchArgument(
                "swarm",
                default_value="torus",
                description="a swarm file, or an installed example's name: "
                + ", ".join(example_swarms()),
            ),
            DeclareLaunchArgument(
                "mode",
                default_value="packed",
                choices=["packed", "per_fls"],
                description="packed: swazure spawn's processes; per_fls: a process per FLS",
            ),
            DeclareLaunchArgument(
                "discovery_server",
                default_value="",
                description="IP[:PORT],...: discover through these Fast DDS Discovery Servers",
            ),
            OpaqueFunction(function=_swarm),
        ]
    )
