#!/bin/bash
# Run a sweep on a Slurm cluster: a job array of shards, one shard a task; the last task to
# finish merges the shards into the CSV a single machine would write.
#
#   sbatch configs/sweep-slurm.sh            # from the repository root, smartteams on PATH
#   sbatch --cpus-per-task=1 --mem=1G configs/sweep-slurm.sh     # on small nodes
#   SWEEP=configs/my-sweep.xml OUT=results/mine sbatch configs/sweep-slurm.sh
#
# Options given to sbatch override the #SBATCH lines below. The output lands in
# results/ (made by the task) and each task's log in slurm-JOB_TASK.out in the folder you
# submit from (Slurm opens it before the script runs, so it must not be in a folder the
# script makes).
#
# Stops keep what was played: 2 minutes before the time limit (and on preemption or
# `scontrol requeue`) the sweep gets SIGTERM, finishes the round in progress, keeps the runs
# it finished and exits; the task is requeued, and its sweep resumes from those runs.
#SBATCH --job-name=smartteams-sweep
#SBATCH --array=0-3
#SBATCH --cpus-per-task=8
#SBATCH --mem=8G
#SBATCH --time=01:00:00
#SBATCH --requeue
#SBATCH --signal=TERM@120
#SBATCH --output=slurm-%A_%a.out
#SBATCH --open-mode=append
set -uo pipefail

SWEEP=${SWEEP:-configs/sweep-demo.xml}
OUT=${OUT:-results/sweep-demo}
mkdir -p "$(dirname "$OUT")"
task="${SLURM_ARRAY_JOB_ID}_${SLURM_ARRAY_TASK_ID}"

# A job step (srun), so that the warning signal and a requeue's SIGTERM reach the sweep
# itself, once.
srun --ntasks=1 smartteams sweep "$SWEEP" -o "$OUT.part$SLURM_ARRAY_TASK_ID.csv" \
    --threads "${SLURM_CPUS_PER_TASK:-1}" --quiet
status=$?
case $status in
    0) ;;
    130 | 143)
        echo "task $task stopped; requeued: it resumes from the runs it finished"
        scontrol requeue "$task"
        exit 0
        ;;
    *) exit $status ;;
esac

# The last task to finish merges: the merge refuses while a shard is missing, so a task
# that finishes before the others leaves it to them.
if smartteams merge "$OUT".part*.csv -o "$OUT.csv" 2>/dev/null; then
    echo "task $task: merged into $OUT.csv"
else
    echo "task $task: shard done; the last task to finish merges"
fi
