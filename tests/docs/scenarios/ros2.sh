# where: host
# docs/ros2.md: rmdd --sim 2 and rmd-ros2 beside it, as the page runs them;
# what goes over DDS is tests/ros2/test_ros2.c's.
. "$RMD_REPO/tests/docs/lib.sh"
command -v rmd-ros2 > /dev/null || skip "rmd-ros2 not built (no Cyclone DDS: the deps cyclonedds-dev, cyclonedds-tools)"
export ROS_DOMAIN_ID=$((100 + $$ % 100))
rmdd --sim 2 > rmdd.log 2>&1 &
pid=$!
wait_for rmdd.log 'running' 20
rmd-ros2 --enable --joint-states rmdd/joint_states --joint-commands rmdd/joint_commands > ros2.log 2>&1 &
bridge=$!
wait_for ros2.log 'publishing rt/rmdd/joint_states, rt/diagnostics; joint commands from rt/rmdd/joint_commands in mode position \(--enable' 20
rmd-ros2 --help | grep -q -- '--max-jump RAD'
stop $bridge TERM
stop $pid
