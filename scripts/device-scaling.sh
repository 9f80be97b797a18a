#!/usr/bin/env bash
# Scaling and memory beyond this project's 2-core machines: run on a machine
# with many cores (the 16-core device machine some tasks are lent), writes its
# findings to OUTDIR. Nothing in the tests depends on it; its committed output
# lives in experiments/device/ and the book quotes it from there.
#
#   scripts/device-scaling.sh BIN OUTDIR [PROCS]
#
# BIN is a release build of hybrid-rt with the `mpi` feature, PROCS the
# processor counts (default 1,2,4,8,16). Open MPI's mpirun must be on the PATH,
# or MPI_TAR names a tar.xz of Debian's Open MPI files to unpack first
# (without overwriting anything there). CITY_SIZES overrides the generated
# cities' triangle counts (default "300000 1500000"), DISTRIBUTIONS the
# distributions the cities are rendered with (default "octree"; the city is
# compiled with its view, so "predicted" works), SECTIONS the parts run
# (default "threads studio city"); QUICK=1 shrinks every run for a rehearsal.
set -u
BIN=$(readlink -f "$1")
OUT=$(readlink -f "$2")
PROCS=${3:-1,2,4,8,16}
CITY_SIZES=${CITY_SIZES:-300000 1500000}
QUICK=${QUICK:-0}
DISTRIBUTIONS=${DISTRIBUTIONS:-octree}
SECTIONS=${SECTIONS:-threads studio city}
section() { [[ " $SECTIONS " == *" $1 "* ]]; }
mkdir -p "$OUT"
WORK=$(mktemp -d)
REPO=$(pwd)

. "$(dirname "$0")/device-mpi.sh"
MPIRUN="mpirun --oversubscribe --bind-to none"

now() { date +%s.%N; }
secs() { echo "$1 $2" | awk '{printf "%.3f", $2 - $1}'; }

{
    echo "date: $(date -u)"
    echo "nproc: $(nproc)"
    lscpu 2>/dev/null | grep -E "Model name|^CPU\(s\)|Thread|Core|Socket|MHz|L3" || true
    free -m 2>/dev/null || true
    uname -a
    "$BIN" --version
    mpirun --version 2>&1 | head -1
} >"$OUT/machine.txt" 2>&1

if [ "$QUICK" = 1 ]; then W=128; REPEAT=1; else W=512; REPEAT=3; fi

# Threads runtime: replicated and octree-distributed against the sequential
# renderer, every picture compared bit for bit by the bench itself.
section threads && "$BIN" bench --scene studio --width $W --height $W --scaling "$PROCS" --repeat $REPEAT \
    >"$OUT/threads-studio.txt" 2>&1
section threads && "$BIN" bench --scene conference --width $W --height $W --scaling "$PROCS" --repeat 1 \
    >"$OUT/threads-conference.txt" 2>&1

# Where the octree-distributed processors' time goes, per processor count
# (threads runtime, the per-processor statistics as JSON).
section threads && for np in ${PROCS//,/ }; do
    "$BIN" render "$REPO/examples/scenes/studio.rad" -vf "$REPO/examples/scenes/studio.vf" -x $W -y $W \
        --procs "$np" --distribution octree --parallel-stats "$WORK/studio-octree-$np.json" \
        -o "$WORK/stats.hdr" >"$WORK/studio-octree-$np.txt" 2>&1
done
section threads && tar -C "$WORK" -cf "$OUT/stats.tar" $(cd "$WORK" && ls studio-octree-*)

# One line per run: what, wall time of the whole command, the render's own
# time, each rank's peak resident memory, whether the picture equals the
# sequential one byte for byte, each rank's memory bound and how far over it
# the rank's peak is.
run_mpi() { # label np reference.hdr args...
    local label=$1 np=$2 ref=$3
    shift 3
    rm -f "$WORK/out.hdr" "$WORK/log"
    local t0 t1
    t0=$(now)
    $MPIRUN -np "$np" "$BIN" render "$@" --runtime mpi --peak-memory -o "$WORK/out.hdr" >"$WORK/log" 2>&1
    local rc=$?
    t1=$(now)
    local peaks same render table
    peaks=$(grep -o "peak resident memory: [0-9]* KiB" "$WORK/log" | awk '{printf "%.1f ", $4/1024}')
    # From rank 0's MPI table, in rank order: each rank's bound (the last
    # column: 1.3 x (resident share + cache budget) + the octree skeleton)
    # and how far its peak (the column before) is over it, where the run
    # has a cache budget. (The ranks print their own peaks above in the
    # order they finish.)
    table=$(awk '/^rank msgs sent/ { t = 1; next }
        t && /^ *[0-9]+ / { b = b $NF " "; if ($NF != "-") o = o sprintf("%.1f ", $(NF-1) - $NF); next }
        { t = 0 }
        END { printf "bound MiB %s| over MiB %s", b, o }' "$WORK/log")
    render=$(grep -o "(render [0-9.]* s)" "$WORK/log" | tr -d '()' | awk '{print $2}')
    if [ -f "$WORK/out.hdr" ] && cmp -s "$WORK/out.hdr" "$ref"; then same=equal; else same=DIFFERENT; fi
    echo "$label | -np $np | rc $rc | wall $(secs "$t0" "$t1") s | render $render s | peak MiB $peaks| $same | $table"
    [ $rc = 0 ] || tail -5 "$WORK/log"
}

run_seq() { # label out.hdr args...
    local label=$1 out=$2
    shift 2
    local t0 t1
    t0=$(now)
    "$BIN" render "$@" --peak-memory -o "$out" >"$WORK/log" 2>&1
    local rc=$?
    t1=$(now)
    local peak
    peak=$(grep -o "peak resident memory: [0-9]* KiB" "$WORK/log" | awk '{printf "%.1f", $4/1024}')
    echo "$label | sequential | rc $rc | wall $(secs "$t0" "$t1") s | peak MiB $peak"
}

# The studio under MPI: octree distribution from the scene file, every count,
# then one and two ranks pinned to two cores (the 2-core machines' case).
section studio && {
    S="$REPO/examples/scenes/studio.rad"
    V="$REPO/examples/scenes/studio.vf"
    run_seq studio "$WORK/studio.hdr" "$S" -vf "$V" -x $W -y $W
    for np in ${PROCS//,/ }; do
        run_mpi studio "$np" "$WORK/studio.hdr" "$S" -vf "$V" -x $W -y $W --distribution octree
    done
    for np in 1 2 1 2 1 2; do
        MPIRUN="taskset -c 0,1 mpirun --oversubscribe --bind-to none" \
            run_mpi "studio on 2 cores" "$np" "$WORK/studio.hdr" "$S" -vf "$V" -x $W -y $W --distribution octree
    done
} >"$OUT/mpi-studio.txt" 2>&1

# Generated cities, compiled: memory per rank and time at every count.
n=0
section city && for size in $CITY_SIZES; do
    n=$((n + 1))
    [ "$QUICK" = 1 ] && size=$((size / 20))
    {
        t0=$(now)
        "$BIN" generate city --size "$size" -o "$WORK/city.rad" 2>&1 | tail -2
        "$BIN" compile "$WORK/city.rad" --view-file "$WORK/city.vf" -o "$WORK/city.hrtc" 2>&1 | tail -2
        echo "generate and compile: $(secs "$t0" "$(now)") s; compiled file $(stat -c %s "$WORK/city.hrtc") bytes"
        run_seq "city $size" "$WORK/city.hdr" "$WORK/city.hrtc" -vf "$WORK/city.vf" -x 128 -y 96
        for d in $DISTRIBUTIONS; do
            for np in ${PROCS//,/ }; do
                run_mpi "city $size compiled, $d" "$np" "$WORK/city.hdr" "$WORK/city.hrtc" -vf "$WORK/city.vf" \
                    -x 128 -y 96 --cache 10% --distribution "$d"
            done
        done
    } >"$OUT/mpi-city-$n.txt" 2>&1
done
rm -rf "$WORK"
