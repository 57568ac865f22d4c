# where: vm
# README.md's rmdctl lines on a CAN interface named can0 (a vcan here, with
# rmd-sim's motors on it), cansend with rmdctl encode, and docs/rmd-sim.md's
# rmd-sim lines on vcan0.
. "$RMD_REPO/tests/docs/lib.sh"
ip link show vcan0 > /dev/null 2>&1 || skip "no vcan0: run through tests/vm/vm-run --vcan 1"
ip link add can0 type vcan
ip link set can0 up
candump -L can0 > frames.out &
cd_pid=$!
rmd-sim --can can0 --motors 1-3 > sim.log 2>&1 &
sim=$!
wait_for sim.log 'ready' 30
scan_until 3 rmdctl scan --bus can0
answered "rmdctl status 3 --bus can0 --json | tee status.json"
grep -q '"motor_id":3' status.json
rc=0; timeout -k 10 -s INT 2 rmdctl monitor --bus can0 > monitor.out 2>&1 || rc=$?; ran_until_stopped $rc
# the two that ask first, answered on a terminal (script gives them one)
tty_answer '\[y/N\]' y "rmdctl move 3 90 --speed 30 --bus can0"
tty_answer '\[y/N\]' y "rmdctl set-timeout 3 100 --bus can0"
cansend can0 $(rmdctl encode --id 1 torque 1.0)
cansend can0 $(rmdctl encode --id 2 position 90 200)
cansend can0 $(rmdctl encode --protocol v2 multi-torque 1 -1 0.5 0)
sleep 0.5
kill $cd_pid; wait $cd_pid || true
for f in 141#A100000064000000 142#A400C80028230000 280#3F00C1FF1F000000; do
	grep -q " can0 $f\$" frames.out || { echo "candump did not see $f"; tail frames.out; exit 1; }
done
# settings into a file and back (unchanged: nothing to write)
answered "rmdctl dump --bus can0 > motors.yaml"
cat motors.yaml
grep -q 'speed_kp' motors.yaml
# unchanged: nothing to ask, nothing to write
answered "rmdctl restore motors.yaml --bus can0 < /dev/null"
stop $sim

rmd-sim --config examples/rmd-sim.conf > s1.log 2>&1 &
p=$!; wait_for s1.log 'ready' 30; scan_until 3 rmdctl scan --bus vcan0; stop $p
# motor 3 drops 5 % of its frames and motor 5 vanishes at 10 s: 5 answer at least
rmd-sim --can vcan0 --motors 1-6 --fault drop:3:0.05 --fault disappear:5:10:15:reboot > s2.log 2>&1 &
p=$!; wait_for s2.log 'ready' 30; scan_until 5 rmdctl scan --bus vcan0; stop $p
rmd-sim --can vcan0 --motors 1 --protocol v2 --set 1:load=2.5 --seed 42 > s3.log 2>&1 &
p=$!; wait_for s3.log 'ready' 30; stop $p
