#!/bin/bash
# Spread one cellmech study over a cluster with a Slurm job array: each array task runs
# a stable shard of the cases into one shared output directory (every case has its own
# folder, so tasks never write the same files), and one last command writes the report.
#
#   sbatch --array=0-7 studies/slurm-array.sh suspended-tension-modulus /shared/modulus
#   # when all tasks are done (or: sbatch --dependency=afterany:JOBID ...):
#   cellmech study suspended-tension-modulus --collect --out /shared/modulus
#
# A task that is killed (time limit, node failure) leaves its interrupted case without a
# record.json: resubmit the same array and only the unfinished cases run.
#SBATCH --job-name=cellmech-study
#SBATCH --cpus-per-task=2
#SBATCH --time=04:00:00
set -euo pipefail
STUDY=${1:?usage: sbatch --array=0-(N-1) slurm-array.sh STUDY OUT}
OUT=${2:?usage: sbatch --array=0-(N-1) slurm-array.sh STUDY OUT}
CELLMECH=${CELLMECH:-cellmech}
N=${SLURM_ARRAY_TASK_COUNT:?run as a Slurm array job (sbatch --array=0-(N-1))}
K=${SLURM_ARRAY_TASK_ID:?run as a Slurm array job}
# The solver's threads: the cores Slurm gave this task.
export RAYON_NUM_THREADS=${SLURM_CPUS_PER_TASK:-1}
exec "$CELLMECH" study "$STUDY" --shard "$K/$N" --out "$OUT" --quiet
