# Concurrent step-based runs of the registered config (plus overrides XS) to MI iterations
# (default 160, 1.57e7 interactions at 4 096 envs), one per seed in SEEDS, each resuming from
# .dev/runs/<TAG>-s<seed> when an earlier call left one there (copy that folder along). Writes
# $OUT/runs-<TAG>-s<seed>.tgz per seed with the run's scalars, configs and only its last
# checkpoint, to keep the archives small (pull.sh unpacks them).
#   SEEDS="1 2 3" TAG=x XS="agent.algorithm.desired_kl=0.02" MI=160 TO=500 bash tools/device/seeds.sh
source tools/device/common.sh
MI=${MI:-160}; TO=${TO:-540}; BIN=${BIN:-train}
mkdir -p /tmp/runs
for s in $SEEDS; do
  r=$TAG-s$s; root=/tmp/runs/$r; res=""; left=$MI
  if [ -d .dev/runs/$r ]; then
    cp -r .dev/runs/$r /tmp/runs/
    last=$(last_checkpoint $root/box_pushing/*/)
    res="--resume"; left=$((MI - last - 1))
  fi
  echo "seed $s: $left iterations $res"
  timeout $TO /tmp/bin/$BIN --backend wgpu --rl-device gpu --seed $s --log-root $root \
    --max-iterations $left $res agent.save_interval=10 $XS > $root.log 2>&1 &
  sleep 2
done
wait
cd /tmp/runs
for s in $SEEDS; do
  r=$TAG-s$s
  newest=$(newest_run $r); last=$(last_checkpoint $newest)
  # Keep every scalars.csv and params, and only the newest run's last checkpoint.
  for d in $r/box_pushing/*/; do
    for f in $d/model_*; do case $f in $newest/model_$last.*) ;; *) rm -f $f;; esac; done
    rm -rf $d/videos
  done
  f=$newest/scalars.csv
  echo "seed $s ($newest, last checkpoint $last): $(awk -F, '$4=="Train/success_rate"{s=$5;i=$1;e=$2} END{print "it " i " steps " e " success " s}' $f)"
  awk -F, '$4=="Train/success_rate" && ($1%10==0){printf "%s:%.2f ", $1, $5} END{print ""}' $f
done
for s in $SEEDS; do tar czf $OUT/runs-$TAG-s$s.tgz $TAG-s$s $TAG-s$s.log; done
