#!/usr/bin/env bash
# Two builds of hybrid-rt side by side on a many-core machine (the device
# machine some tasks are lent): thread scaling of both on the studio and the
# conference room, one and two MPI ranks of both pinned to two cores, and the
# second build's per-processor statistics. See scripts/device-mpi.sh for
# MPI_TAR.
#
#   scripts/device-compare.sh BASE NEW OUTDIR [PROCS]
#
# CONFERENCE="new base" (the default) names the builds the conference room
# is rendered with (it takes minutes each on 16 cores).
set -u
BASE=$(readlink -f "$1")
NEW=$(readlink -f "$2")
OUT=$(readlink -f "$3")
PROCS=${4:-1,2,4,8,16}
mkdir -p "$OUT"
WORK=$(mktemp -d)
. "$(dirname "$0")/device-mpi.sh"
S=examples/scenes/studio.rad
V=examples/scenes/studio.vf
{
    echo "date: $(date -u)"
    echo "nproc: $(nproc)"
    lscpu 2>/dev/null | grep -E "Model name" || true
} >"$OUT/machine.txt"

for b in base new; do
    bin=$BASE
    [ $b = new ] && bin=$NEW
    "$bin" bench --scene studio --width 512 --height 512 --scaling "$PROCS" --repeat 3 \
        >"$OUT/threads-studio-$b.txt" 2>&1
done
for b in ${CONFERENCE:-new base}; do
    bin=$BASE
    [ $b = new ] && bin=$NEW
    "$bin" bench --scene conference --width 512 --height 512 --scaling "$PROCS" --repeat 1 \
        >"$OUT/threads-conference-$b.txt" 2>&1
done

# One and two ranks on two cores, the builds interleaved; the render's own
# time as each run reports it.
{
    for round in 1 2; do
        for np in 1 2; do
            for b in base new; do
                bin=$BASE
                [ $b = new ] && bin=$NEW
                t=$(taskset -c 0,1 mpirun --oversubscribe --bind-to none -np $np "$bin" render "$S" -vf "$V" \
                    -x 512 -y 512 --runtime mpi --distribution octree -o "$WORK/m.hdr" 2>&1 |
                    grep -o "(render [0-9.]* s)")
                echo "$b | -np $np | round $round | $t"
            done
        done
    done
} >"$OUT/mpi-studio-2cores.txt" 2>&1

for np in ${PROCS//,/ }; do
    "$NEW" render "$S" -vf "$V" -x 512 -y 512 --procs "$np" --distribution octree \
        --parallel-stats "$WORK/studio-octree-$np.json" -o "$WORK/s.hdr" >"$WORK/studio-octree-$np.txt" 2>&1
done
tar -C "$WORK" -cf "$OUT/stats-new.tar" $(cd "$WORK" && ls studio-octree-*)
rm -rf "$WORK"
