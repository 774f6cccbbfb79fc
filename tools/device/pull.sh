# On the development machine: bash tools/device/pull.sh <files_at>/runs-<TAG>.tgz replaces
# .dev/runs/<TAG>-s* with the runs of a seeds.sh call and keeps their logs in .dev/runlogs.
set -e
t=$(mktemp -d); tar xzf "$1" -C $t
mkdir -p .dev/runs .dev/runlogs
for d in $t/*/; do n=$(basename $d); rm -rf .dev/runs/$n; mv $d .dev/runs/; done
mv $t/*.log .dev/runlogs/ 2>/dev/null || true
