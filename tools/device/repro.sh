# Does cubecl's persistent autotune cache make GPU-learner runs repeatable? Runs the registered
# step-based task N times in a row (default 3) with the same seed for IT iterations (default 8),
# each process reading and writing the cache under target/environment (cubecl's default place),
# which starts empty. Prints each run's first-iteration wall time and whether its logged values
# (wall-clock and Perf/ columns dropped) are identical to the previous run's.
#   BIN=train IT=8 N=3 XS="" bash tools/device/repro.sh
source tools/device/common.sh
IT=${IT:-8}; N=${N:-3}; BIN=${BIN:-train}
rm -rf target/environment /tmp/rp; mkdir -p /tmp/rp
for r in $(seq 1 $N); do
  /tmp/bin/$BIN --backend wgpu --rl-device gpu --seed 42 --log-root /tmp/rp/$r \
    --max-iterations $IT agent.save_interval=1000 $XS > /tmp/rp/$r.log 2>&1 || tail -5 /tmp/rp/$r.log
  f=$(ls /tmp/rp/$r/box_pushing/*/scalars.csv)
  awk -F, '$4 !~ /^Perf\// {print $1","$2","$4","$5}' $f > /tmp/rp/$r.values
  echo "run $r: first iteration at $(awk -F, 'NR==2{print $3}' $f) s, last success $(awk -F, '$4=="Train/success_rate"{s=$5} END{print s}' $f), cache $(du -sh target/environment 2>/dev/null | cut -f1)"
  if [ $r -gt 1 ]; then
    if cmp -s /tmp/rp/$((r-1)).values /tmp/rp/$r.values; then echo "  identical to run $((r-1))"
    else echo "  differs from run $((r-1)) from line $(cmp /tmp/rp/$((r-1)).values /tmp/rp/$r.values | awk '{print $NF}')"; fi
  fi
done
grep -ih "autotune" /tmp/rp/*.log | sort | uniq -c | head -20
