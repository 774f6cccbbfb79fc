# On the machine that builds: bash tools/device/pull.sh <results>/runs-<TAG>-s*.tgz replaces
# .dev/runs/<TAG>-s<seed> with the runs of a seeds.sh call and keeps their logs in .dev/runlogs.
set -e
t=$(mktemp -d); for f in "$@"; do tar xzf "$f" -C $t; done
mkdir -p .dev/runs .dev/runlogs
for d in $t/*/; do n=$(basename $d); rm -rf .dev/runs/$n; mv $d .dev/runs/; done
mv $t/*.log .dev/runlogs/ 2>/dev/null || true
