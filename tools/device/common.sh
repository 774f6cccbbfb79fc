# Sourced by the device scripts (run from the repository root on the GPU machine): installs the
# Vulkan loader from .gl/*.deb, unpacks the binaries .dev/<name>.xz to /tmp/bin/<name>, and
# defines `col FILE TAG` (one tag's column of a scalars.csv as "iteration,value" lines).
for f in .gl/*.deb; do dpkg -x "$f" /; done; ldconfig
export VK_DRIVER_FILES=/usr/local/nvidia/share/vulkan/icd.d/nvidia_icd.json
mkdir -p /tmp/bin
for f in .dev/*.xz; do
  [ -e "$f" ] || continue
  n=$(basename "$f" .xz); xz -dc "$f" > /tmp/bin/$n && chmod +x /tmp/bin/$n
done
nvidia-smi --query-gpu=name,driver_version --format=csv,noheader
col() { awk -F, -v t="$2" '$4==t{print $1","$5}' "$1"; }
