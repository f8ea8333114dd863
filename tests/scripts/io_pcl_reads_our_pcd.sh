#!/usr/bin/env bash
# PCL (Debian's pcl-tools) reads the PCD files hazmap writes, and hazmap reads PCL's output and
# PCL's binary_compressed PCDs. Args: SOURCE_DIR BINARY_DIR HAZMAP_CLI
set -euo pipefail
src=$1; bin=$2; hazmap=$3
data=${HAZMAP_SHARED_DATA_DIR:-$src/../shared/data}  # CTest sets it to the configured folder
[[ -d "$data" ]] || { echo "FAIL: shared test data not found: $data (configure with -DHAZMAP_SHARED_DATA_DIR=<dir>)"; exit 1; }
for tool in pcl_pcd2ply pcl_convert_pcd_ascii_binary; do
  command -v "$tool" > /dev/null || { echo "FAIL: $tool missing (scripts/install-deps.sh installs pcl-tools)"; exit 1; }
done
tmp=$(mktemp -d "$bin/io_pcl.XXXXXX")
trap 'rm -rf "$tmp"' EXIT

points_of() {  # hazmap's point count of a cloud file
  "$hazmap" info --json "$1" | sed -n 's/^  "points": \([0-9]*\),\{0,1\}$/\1/p'
}

scan="$data/kitti-semantic-sample/velodyne/000000.bin"
for enc in binary ascii binary_compressed; do
  "$hazmap" convert --classes semantic-kitti --pcd-encoding "$enc" "$scan" "$tmp/ours_$enc.pcd" > /dev/null
  # pcl_pcd2ply exits 0 even on some failures, so check its output file and message.
  out=$(pcl_pcd2ply "$tmp/ours_$enc.pcd" "$tmp/pcl_$enc.ply" 2>&1) || { echo "FAIL: pcl_pcd2ply on $enc: $out"; exit 1; }
  if ! grep -q "124668 points" <<< "$out"; then
    echo "FAIL: PCL did not load 124668 points from our $enc PCD:"; echo "$out"; exit 1
  fi
  [[ -s "$tmp/pcl_$enc.ply" ]] || { echo "FAIL: PCL wrote no PLY for $enc"; exit 1; }
  n=$(points_of "$tmp/pcl_$enc.ply")
  [[ "$n" == 124668 ]] || { echo "FAIL: hazmap read $n points from PCL's PLY ($enc)"; exit 1; }
  grep -a -q "property .* label" "$tmp/pcl_$enc.ply" || { echo "FAIL: PCL dropped the label field ($enc)"; exit 1; }
done

# PCL's own binary_compressed writer → hazmap.
pcl_convert_pcd_ascii_binary "$data/scan-pair/251370668.pcd" "$tmp/pcl_compressed.pcd" 2 > /dev/null 2>&1
grep -a -q "DATA binary_compressed" "$tmp/pcl_compressed.pcd" || { echo "FAIL: PCL did not compress"; exit 1; }
n=$(points_of "$tmp/pcl_compressed.pcd")
[[ "$n" == 69088 ]] || { echo "FAIL: hazmap read $n points from PCL's binary_compressed PCD"; exit 1; }
# ... and identical to the binary original, byte for byte after conversion to .bin.
"$hazmap" convert "$tmp/pcl_compressed.pcd" "$tmp/a.bin" > /dev/null
"$hazmap" convert "$data/scan-pair/251370668.pcd" "$tmp/b.bin" > /dev/null
cmp -s "$tmp/a.bin" "$tmp/b.bin" || { echo "FAIL: PCL's compressed PCD decodes differently"; exit 1; }
echo "OK: PCL reads hazmap's binary, ascii and binary_compressed PCDs; hazmap reads PCL's PLY and compressed PCD"
