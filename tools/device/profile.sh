# Per-kernel GPU time from cubecl's profiling log (a cubecl.toml in the working directory with
# [profiling.logger] level = "basic"; cubecl then synchronises after every kernel, so only the
# kernels' own times are meaningful): NE envs (default 65 536) with 5 epochs x 4 minibatches,
# MI iterations (default 3). Prints the kernels by total time; $OUT/prof.log.xz is the raw log.
source tools/device/common.sh
w=$(mktemp -d /tmp/prof.XXXX); cd $w
printf '[profiling.logger]\nlevel = "basic"\nfile = "%s/prof.log"\n' $w > cubecl.toml
timeout ${TO:-200} /tmp/bin/train --backend wgpu --rl-device gpu --seed 1 --log-root $w/logs \
  --num-envs ${NE:-65536} --max-iterations ${MI:-3} agent.algorithm.num_learning_epochs=5 \
  agent.algorithm.num_mini_batches=4 > out.log 2>&1
echo "rc=$?"
awk -F'|' 'NF>=3 { d=$2; gsub(/ /,"",d); v=d+0; if (d ~ /ns$/) v/=1e6; else if (d ~ /µs$/) v/=1e3;
  else if (d ~ /ms$/) v=v; else if (d ~ /s$/) v*=1e3; n=substr($3,1,150); s[n]+=v; c[n]++; tot+=v }
  END { printf "total %.1f ms\n", tot; for (k in s) printf "%10.1f ms %7d %s\n", s[k], c[k], k }' \
  prof.log | sort -rn | head -45
xz -T4 -c prof.log > $OUT/prof.log.xz
