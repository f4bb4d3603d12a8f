# ROS 2 launch file: Listings 2 and 3 for two robots side by side (`ros2 launch launch_scripts/two_robots.launch.py`),
# for users with a ROS 2 installation. Each robot's four processes run under its own namespace with settings
# from robots.yaml, as a launch_ros Node(namespace=..., parameters=[...]) passes them; build first with
# `cargo build --bin deliberative`. Without ROS, two_robots.sh beside this file runs the same command lines.
import os

from launch import LaunchDescription
from launch.actions import ExecuteProcess

HERE = os.path.dirname(os.path.abspath(__file__))
BIN = os.environ.get(
    'RADAR_EXAMPLES', os.path.join(HERE, '..', 'target', 'debug')) + '/deliberative'
PARAMS = os.path.join(HERE, 'robots.yaml')


def robot(ns: str) -> list:
    ros_args = ['--ros-args', '-r', f'__ns:=/{ns}', '--params-file', PARAMS]
    return [
        ExecuteProcess(cmd=[BIN, role] + ros_args, name=f'{ns}_{role}', output='screen')
        for role in ('test_event', 'test_event2', 'test_response', 'main')
    ]


def generate_launch_description() -> LaunchDescription:
    return LaunchDescription(robot('robot1') + robot('robot2'))
