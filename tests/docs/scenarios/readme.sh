# where: host
# README.md: rmdd on simulated motors, rmdctl against them, encode.
. "$RMD_REPO/tests/docs/lib.sh"

rmdd --sim > rmdd.log 2>&1 &
pid=$!
wait_for rmdd.log 'running' 20
kill -USR1 $pid
wait_for rmdd.log 'cycles' 10
stop $pid
grep -E 'motor' rmdd.log | head -3

rmdctl scan --bus sim:1-3 > scan.out
cat scan.out
[ "$(grep -c -E '^ *[0-9]' scan.out)" -ge 3 ] || { echo "scan found fewer than 3 motors"; exit 1; }

# the frames the README prints beside these commands
[ "$(rmdctl encode --id 1 torque 1.0)" = 141#A100000064000000 ]
[ "$(rmdctl encode --id 2 position 90 200)" = 142#A400C80028230000 ]
[ "$(rmdctl encode --protocol v2 multi-torque 1 -1 0.5 0)" = 280#3F00C1FF1F000000 ]

# --trace as candump -l lines that rmdctl decode reads back
rmdctl status 1 --bus sim:1-3 --trace 2>trace.log && rmdctl decode trace.log > decoded.out
cat decoded.out
[ "$(grep -c 'motor 1' decoded.out)" -ge 2 ]
