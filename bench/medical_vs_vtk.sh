#!/usr/bin/env bash
# Runs bench_medical (isoforge) and vtk_flying_edges.py (VTK 9, Debian python3-vtk9) on the same volumes and
# prints them side by side with the ratios. Usage: bench/medical_vs_vtk.sh [BUILD_DIR] [--quick]
set -euo pipefail
here=$(cd "$(dirname "$0")" && pwd)
build=${1:-$here/../build}
quick=${2:-}
shared=$here/../../shared/data
[ -x /usr/bin/python3 ] && /usr/bin/python3 -c "import vtk" 2>/dev/null || {
    echo "needs Debian's python3-vtk9 (apt-get install python3-vtk9): a benchmark-only dependency" >&2; exit 1; }
ours=$("$build/bench/bench_medical" $quick)
theirs=$(/usr/bin/python3 "$here/vtk_flying_edges.py" "$shared" $quick)
get() { printf '%s\n%s\n' "$ours" "$theirs" | awk -v k="$1" '$1 == k { print $2 }'; }
printf '%-44s %12s %12s %8s\n' "" isoforge "VTK" "VTK/iso"
row() { printf '%-44s %12s %12s %7.2fx\n' "$1" "$2" "$3" "$(echo "$3 / $2" | bc -l)"; }
row "CT 512x512x48: read DICOM (s)" "$(get ct_read)" "$(get vtk_ct_read)"
row "CT: mesh bone at 300 HU (s)" "$(get ct_mesh)" "$(get vtk_ct_mesh)"
printf '%-44s %12s %12s\n' "CT: triangles" "$(get ct_triangles)" "$(get vtk_ct_triangles)"
printf '%-44s %12s\n' "CT: isoforge sparse conversion (s)" "$(get ct_convert)"
printf '%-44s %12s %12s\n' "CT: peak memory (MiB; VTK: whole process)" "$(get ct_peak_mib)" "$(get vtk_peak_mib)"
row "AAL 116 labels, marching cubes per label (s)" "$(get labels_seconds)" "$(get vtk_labels_seconds)"
printf '%-44s %12s %12s\n' "AAL: triangles" "$(get labels_triangles)" "$(get vtk_labels_triangles)"
row "AAL 116 labels, shared boundaries (s)" "$(get shared_seconds)" "$(get vtk_labels_seconds)"
printf '%-44s %12s\n' "AAL shared: triangles" "$(get shared_triangles)"
if [ "$(get per_label_seconds)" != "-1.0000" ]; then
    printf '%-44s %12s  (%.1fx slower than all labels at once)\n' "AAL: single-iso core once per label (s)" \
        "$(get per_label_seconds)" "$(echo "$(get per_label_seconds) / $(get labels_seconds)" | bc -l)"
fi
