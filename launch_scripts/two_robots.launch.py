# ROS 2 launch file: Listings 2 and 3 for two robots side by side, each robot's four processes under its own
# namespace with its settings from robots.yaml, started as the installed program `deliberative` of the colcon
# package radar_ros_examples (README, "In a colcon workspace"):
#   ros2 launch radar_ros_examples two_robots.launch.py
# Node(namespace=..., parameters=[...]) passes `--ros-args -r __ns:=/robotN --params-file robots.yaml`; without
# ROS, two_robots.sh beside this file runs the same command lines from a cargo build.
import os

from launch import LaunchDescription
from launch_ros.actions import Node

PARAMS = os.path.join(os.path.dirname(os.path.abspath(__file__)), 'robots.yaml')


def robot(ns: str) -> list:
    return [
        Node(package='radar_ros_examples', executable='deliberative', arguments=[role], namespace=ns,
             parameters=[PARAMS], output='screen')
        for role in ('test_event', 'test_event2', 'test_response', 'main')
    ]


def generate_launch_description() -> LaunchDescription:
    return LaunchDescription(robot('robot1') + robot('robot2'))
