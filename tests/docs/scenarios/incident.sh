# where: host
# README.md "After an incident": a motor lost on the simulated bus, its
# recording, and the post-mortem commands run in its folder as shown.
. "$RMD_REPO/tests/docs/lib.sh"
cat > c.yaml <<EOY
safety: {missed_replies_lost: 10, lost_motor_action: motor}
probe: {on_missing: start}
incidents: {dir: "$PWD/incidents", seconds_before: 1, seconds_after: 0.3}
buses:
  - name: sim0
    type: sim
    sim:
      seed: 7
      faults:
        - {kind: disappear, motor: 3, start_s: 1.5, end_s: 30, param: 1}
motors:
  - {name: a, bus: sim0, id: 1, mode: torque, torque_constant_nm_a: 2.0}
  - {name: b, bus: sim0, id: 2, mode: speed, torque_constant_nm_a: 2.0}
  - {name: c, bus: sim0, id: 3, mode: position, torque_constant_nm_a: 2.0}
EOY
rmdd --config c.yaml --lcm-url memq:// > rmdd.log 2>&1 &
pid=$!
wait_for rmdd.log 'incident recorded in .*-lost' 20
stop $pid
dir=$(ls -d incidents/*-lost | head -n 1)
cd "$dir"
cat summary.txt
grep -q '^What: *sim0: motor 3 (c): ready -> lost' summary.txt
grep ' 243#' frames-sim0.log | tail -1 | rmdctl decode      # motor 3's last reply
grep ' 243#' frames-sim0.log | tail -1 | rmdctl decode | grep -q 'motor 3 reply'
grep ' 143#' frames-sim0.log | tail -2                       # the requests it never answered
awk -F, '$4 == "c" && $5 != prev { print $1, $5, "reply age", $14; prev = $5 }' states.csv
awk -F, '$4 == "c" && $5 != prev { print $5; prev = $5 }' states.csv | grep -q '^lost$'
rmdctl decode --json frames-sim0.log > frames.jsonl         # for a script or a notebook
[ "$(wc -l < frames.jsonl)" -eq "$(grep -c '^(' frames-sim0.log)" ]
