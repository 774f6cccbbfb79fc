# Greedy (mean-action) success of trained checkpoints: for each run folder .dev/runs/<name> in
# RUNS, plays the newest checkpoint of its newest run for one episode per env (NE envs, env seed
# ES, the wgpu backend) with the `play` build (.dev/play.xz), and prints the summary over those
# episodes next to the run's last training-time success rate (stochastic actions).
#   RUNS="adam-s1 adam-s3" NE=4096 bash tools/device/eval.sh
source tools/device/common.sh
NE=${NE:-4096}; ES=${ES:-1000}
for r in $RUNS; do
  newest=$(newest_run .dev/runs/$r); last=$(last_checkpoint $newest)
  train=$(awk -F, '$4=="Train/success_rate"{s=$5} END{printf "%.3f", s}' $newest/scalars.csv)
  greedy=$(/tmp/bin/play --checkpoint $newest/model_$last --backend wgpu --num-envs $NE \
    --seed $ES 2>&1 | awk '/episodes \(mean actions\)/{p=1} p && /Metrics\/target\/success/{printf "%.4f", $2}')
  echo "$r model_$last: training success $train, greedy success $greedy"
done
