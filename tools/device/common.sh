# Sourced by the scripts here (run from the repository root on an H100 GPU machine): installs the
# Vulkan loader from .gl/*.deb, unpacks the binaries .dev/<name>.xz to /tmp/bin/<name>, and
# defines `col FILE TAG` (one tag's column of a scalars.csv as "iteration,value" lines),
# `newest_run ROOT` (the newest run directory under ROOT/box_pushing) and `last_checkpoint DIR...`
# (the highest checkpoint iteration in the run directories DIR).
for f in .gl/*.deb; do dpkg -x "$f" /; done; ldconfig
export VK_DRIVER_FILES=/usr/local/nvidia/share/vulkan/icd.d/nvidia_icd.json
mkdir -p /tmp/bin
for f in .dev/*.xz; do
  [ -e "$f" ] || continue
  n=$(basename "$f" .xz); xz -dc "$f" > /tmp/bin/$n && chmod +x /tmp/bin/$n
done
nvidia-smi --query-gpu=name,driver_version --format=csv,noheader
col() { awk -F, -v t="$2" '$4==t{print $1","$5}' "$1"; }
newest_run() { ls -d $1/box_pushing/*/ | sort | tail -1; }
last_checkpoint() {
  for d in "$@"; do ls $d/model_*.json 2>/dev/null; done |
    sed 's/.*model_\([0-9]*\).json/\1/' | sort -n | tail -1
}
