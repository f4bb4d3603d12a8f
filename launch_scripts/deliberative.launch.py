# ROS 2 launch file for Listings 2 and 3 (`ros2 launch launch_scripts/deliberative.launch.py`), for users who
# have a ROS 2 installation. Each component is its own process; build first with
# `cargo build --bin deliberative`. Without ROS, use deliberative.sh beside this file.
import os

from launch import LaunchDescription
from launch.actions import ExecuteProcess

HERE = os.path.dirname(os.path.abspath(__file__))
BIN = os.environ.get(
    'RADAR_EXAMPLES', os.path.join(HERE, '..', 'target', 'debug')) + '/deliberative'


def generate_launch_description():
    components = [
        ExecuteProcess(cmd=[BIN, role], name=role, output='screen')
        for role in ('test_event', 'test_event2', 'test_response')
    ]
    main = ExecuteProcess(cmd=[BIN, 'main'], name='deliberative', output='screen')
    return LaunchDescription(components + [main])
