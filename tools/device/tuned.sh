# Which kernels cubecl's autotune chooses for a training run: an empty kernel cache, cubecl's
# minimal autotune log (a cubecl.toml in the working directory), MI iterations (default 2) at
# NE envs (default 131 072) with 5 epochs x 4 minibatches. Prints the chosen kernels by count;
# $OUT/autotune-<BIN>.log is the log. A `sum_one_shot` among them adds partial sums atomically,
# so runs would not repeat bit for bit (docs/training.md).
source tools/device/common.sh
w=$(mktemp -d /tmp/at.XXXX)
printf '[autotune.logger]\nlevel = "minimal"\nfile = "%s/autotune.log"\n' $w > cubecl.toml
rm -rf target/environment
timeout 300 /tmp/bin/${BIN:-train} --backend wgpu --rl-device gpu --seed 1 --log-root $w/logs \
  --num-envs ${NE:-131072} --max-iterations ${MI:-2} agent.algorithm.num_learning_epochs=5 \
  agent.algorithm.num_mini_batches=4 > $w/out.log 2>&1
echo "rc=$?"; rm cubecl.toml
cp $w/autotune.log $OUT/autotune-${BIN:-train}.log
grep "Fastest result" $w/autotune.log | sed 's/Fastest result \([^-]*\)-.*/\1/' | sort | uniq -c | sort -rn
