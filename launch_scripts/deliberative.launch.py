# ROS 2 launch file for Listings 2 and 3: each component its own process, started as the installed program
# `deliberative` of the colcon package radar_ros_examples (README, "In a colcon workspace"):
#   ros2 launch radar_ros_examples deliberative.launch.py
# Without ROS, deliberative.sh beside this file runs the same command lines from a cargo build.
from launch import LaunchDescription
from launch_ros.actions import Node


def generate_launch_description() -> LaunchDescription:
    # each role names its own node (test_event, test_event2, test_response, deliberative)
    return LaunchDescription([
        Node(package='radar_ros_examples', executable='deliberative', arguments=[role], output='screen')
        for role in ('test_event', 'test_event2', 'test_response', 'main')
    ])
