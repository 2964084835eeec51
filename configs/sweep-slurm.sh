#!/bin/bash
# Run configs/sweep-demo.xml on a Slurm cluster: a job array of 4 shards, then one job that
# merges their CSVs into the file a single machine would write.
#
#   sbatch configs/sweep-slurm.sh          # from the repository root, smartteams on PATH
#
# Each array task runs `smartteams sweep` with no --shard: it takes its shard from
# SLURM_ARRAY_TASK_ID (minus SLURM_ARRAY_TASK_MIN) of SLURM_ARRAY_TASK_COUNT. A task that is
# preempted or times out resumes where it stopped when requeued: finished runs are kept.
#SBATCH --job-name=smartteams-sweep
#SBATCH --array=0-3
#SBATCH --cpus-per-task=8
#SBATCH --mem=8G
#SBATCH --time=01:00:00
#SBATCH --requeue
#SBATCH --output=results/slurm-%A_%a.out
set -euo pipefail

SWEEP=${SWEEP:-configs/sweep-demo.xml}
OUT=${OUT:-results/sweep-demo}
mkdir -p "$(dirname "$OUT")"

smartteams sweep "$SWEEP" -o "$OUT.part$SLURM_ARRAY_TASK_ID.csv" --threads "${SLURM_CPUS_PER_TASK:-1}" --quiet

# The last task to finish merges (the merge refuses to run while a shard is missing, so a
# task that finishes early just leaves it to the others).
if smartteams merge "$OUT".part*.csv -o "$OUT.csv" 2>/dev/null; then
    echo "merged into $OUT.csv"
else
    echo "shard $SLURM_ARRAY_TASK_ID done; waiting for the others to merge"
fi
