#!/bin/sh
# Reproduces docs/suspended-cell-validation.md: the suspended cell's tension test in every
# coupling mode with the eight disruption models (MTs on an elastic foundation in a study
# of their own), the compression test in the coupling modes that complete it with the same
# eight, and the mesh convergence of both tests.
# Each study is resumable (rerun to finish an interrupted one) and writes its own report.
#
#   sh studies/suspended-validation.sh [OUT] [JOBS]     # about 3 h on 2 cores (estimated from the single runs on the 6912-hex8 default mesh)
set -eu
OUT=${1:-validation}
JOBS=${2:-1}
CELLMECH=${CELLMECH:-cellmech}
HERE=$(dirname "$0")
# A study whose cases fail exits with 1 after writing its report: go on to the next.
"$CELLMECH" study suspended-tension-coupling --out "$OUT/tension-coupling" --jobs "$JOBS" ||
    echo "tension-coupling: some cases failed (listed in its report)"
"$CELLMECH" study suspended-compression-coupling --out "$OUT/compression-coupling" --jobs "$JOBS" ||
    echo "compression-coupling: some cases failed (listed in its report)"
"$CELLMECH" study "$HERE/suspended-tension-foundation.toml" --out "$OUT/tension-foundation" --jobs "$JOBS" ||
    echo "tension-foundation: some cases failed (listed in its report)"
"$CELLMECH" study "$HERE/suspended-compression-foundation.toml" --out "$OUT/compression-foundation" --jobs "$JOBS" ||
    echo "compression-foundation: some cases failed (listed in its report)"
"$CELLMECH" study "$HERE/suspended-tension-mesh.toml" --out "$OUT/tension-mesh" --jobs "$JOBS" ||
    echo "tension-mesh: some cases failed (listed in its report)"
"$CELLMECH" study "$HERE/suspended-compression-mesh.toml" --out "$OUT/compression-mesh" --jobs "$JOBS" ||
    echo "compression-mesh: some cases failed (listed in its report)"
echo "reports: $OUT/*/report.md"
