# A/B of train builds on one host, runs one after the other: BIG names the builds run at
# NE envs (default 65 536) with the paper's 5 epochs x 4 minibatches (BIT iterations, default 6), SMALL
# those run at 4 096 envs with the registered config (IT iterations, default 12). A build name <n> is the
# binary .dev/<n>.xz, e.g. BIG="train train_old train train_old" SMALL="train train_old".
# XS adds config overrides to every run (e.g. XS="agent.policy.actor_hidden_dims=[512,256,128]").
# Each run's scalars.csv comes back as $OUT/<k>-<build>-<envs>.csv (k counts the runs), so that
# two builds' logs can be compared value by value (`grep -v Perf/`).
source tools/device/common.sh
k=0
run() { # binary envs iterations overrides...
  d=$(mktemp -d /tmp/ab.XXXX); t0=$(date +%s); k=$((k+1))
  timeout 170 /tmp/bin/$1 --backend wgpu --rl-device gpu --seed 1 --log-root $d --num-envs $2 \
    --max-iterations $3 "${@:4}" $XS > $d/out.log 2>&1
  rc=$?; f=$(ls $d/*/*/scalars.csv | head -1); cp $f $OUT/$k-$1-$2.csv
  echo "== $1 $2 envs $XS rc=$rc wall=$(( $(date +%s) - t0 ))s"
  for t in Perf/total_fps Perf/collection_time Perf/env_time Perf/physics_time Perf/policy_time \
           Perf/learning_time Loss/value_function Loss/learning_rate; do
    echo " $t: $(col $f $t | awk -F, '{printf "%.4g ",$2}')"; done
}
for b in $BIG; do
  run $b ${NE:-65536} ${BIT:-6} agent.algorithm.num_learning_epochs=5 agent.algorithm.num_mini_batches=4
done
for b in $SMALL; do run $b 4096 ${IT:-12}; done
