# CPU profile of the host side of training: `perf record` (997 Hz, no call graphs) on a `train`
# process at NE envs (default 131 072) with 5 epochs x 4 minibatches, for PS seconds (default 30)
# from its third logged iteration on. BIN names the build (default train_sym: keep its symbols,
# `strip --strip-debug`, or perf shows addresses only); .dev/perfkit.tar.xz holds perf and its
# libraries (README). Prints the run's phase times; $OUT/perf.data.xz is the profile, to read on
# the machine that builds, with the same binary at /tmp/bin/$BIN (see README).
source tools/device/common.sh
mkdir -p /tmp/pk && tar xJf .dev/perfkit.tar.xz -C /tmp/pk
P=/tmp/pk/perfkit; export LD_LIBRARY_PATH=$P/lib
$P/perf --version || { export LD_LIBRARY_PATH=$P/lib:$P/core; $P/perf --version; }
d=$(mktemp -d /tmp/pf.XXXX)
/tmp/bin/${BIN:-train_sym} --backend wgpu --rl-device gpu --seed 1 --log-root $d \
  --num-envs ${NE:-131072} --max-iterations ${MI:-16} agent.algorithm.num_learning_epochs=5 \
  agent.algorithm.num_mini_batches=4 > $d/out.log 2>&1 &
pid=$!
for i in $(seq 1 300); do
  f=$(ls $d/*/*/scalars.csv 2>/dev/null | head -1)
  [ -n "$f" ] && [ "$(col $f Perf/total_fps | wc -l)" -ge 3 ] && break; sleep 1
done
$P/perf record -F 997 -p $pid -o $d/perf.data -- sleep ${PS:-30} 2>&1 | tail -1
wait $pid; echo "train rc=$?"
f=$(ls $d/*/*/scalars.csv | head -1)
for t in Perf/total_fps Perf/collection_time Perf/env_time Perf/physics_time Perf/policy_time \
         Perf/learning_time; do
  echo " $t: $(col $f $t | awk -F, '{printf "%.4g ",$2}')"; done
cp $d/perf.data $OUT/ && xz -T8 -1 $OUT/perf.data
