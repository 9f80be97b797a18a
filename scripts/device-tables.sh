#!/usr/bin/env bash
# The markdown tables of a scripts/device-scaling.sh run: reads DIR's raw
# outputs, prints the tables the book includes (DIR/tables.md is this
# script's output, checked by tests/layout.rs).
#
#   scripts/device-tables.sh DIR > DIR/tables.md
set -euo pipefail
dir=$1

machine() {
    local cores model
    cores=$(sed -n 's/^nproc: //p' "$dir/machine.txt")
    model=$(sed -n 's/^Model name: *//p' "$dir/machine.txt")
    echo "$cores cores ($model), $(sed -n 's/^date: //p' "$dir/machine.txt")"
}

# A bench's table: the line naming the scene, then the table itself.
bench() {
    grep -E '^(examples/|\|)' "$1"
}

# mpi-*.txt lines: "what | -np N | rc R | wall W s | render T s | peak MiB a b c | equal"
# (later runs add " | bound MiB x y z | over MiB u v w", each rank's bound and
# how far its peak is over it, in rank order: then the table has the most any
# rank is over) or "what | sequential | rc R | wall W s | peak MiB p".
mpi() {
    local bounds=0
    grep -q ' | over MiB ' "$1" && bounds=1
    if [ $bounds = 1 ]; then
        echo "| run | peak resident memory per rank (MiB) | most over its bound (MiB) | wall time (s) | render (s) | picture |"
        echo "| --- | --- | --- | --- | --- | --- |"
    else
        echo "| run | peak resident memory per rank (MiB) | wall time (s) | render (s) | picture |"
        echo "| --- | --- | --- | --- | --- |"
    fi
    awk -F ' [|] ' -v bounds=$bounds '
        / [|] sequential [|] / {
            split($5, p, " ")
            sub(/^wall /, "", $4); sub(/ s$/, "", $4)
            printf "| sequential renderer, whole scene | %s |%s %s | - | reference |\n", p[3], bounds ? " - |" : "", $4
            next
        }
        / [|] -np / {
            n = split($6, p, " ")
            lo = p[3]; hi = p[3]
            for (i = 4; i <= n; i++) { if (p[i] + 0 < lo + 0) lo = p[i]; if (p[i] + 0 > hi + 0) hi = p[i] }
            range = (n == 3) ? lo : lo " to " hi
            over = ""
            if (bounds) {
                m = split($9, o, " ")
                worst = "-"
                for (i = 3; i <= m; i++) if (worst == "-" || o[i] + 0 > worst + 0) worst = o[i]
                over = " " worst " |"
            }
            sub(/^wall /, "", $4); sub(/ s$/, "", $4)
            sub(/^render /, "", $5); sub(/ s$/, "", $5)
            printf "| `%s`, %s | %s |%s %s | %s | %s |\n", $2, $1, range, over, $4, $5, $7
        }' "$1"
}

if [ -f "$dir/threads-studio-base.txt" ]; then
    # A scripts/device-compare.sh run: two builds side by side.
    echo "Measured on $(machine) by \`scripts/device-compare.sh\`: two builds, \`base\` and \`new\` (see the README beside this file)."
    for b in base new; do
        echo
        echo "**Threads runtime, the studio, \`$b\`** (\`bench --scene studio --width 512 --height 512 --scaling 1,2,4,8,16 --repeat 3\`):"
        echo
        bench "$dir/threads-studio-$b.txt"
    done
    for b in base new; do
        [ -f "$dir/threads-conference-$b.txt" ] || continue
        echo
        echo "**Threads runtime, the conference room, \`$b\`** (the same with \`--scene conference --repeat 1\`):"
        echo
        bench "$dir/threads-conference-$b.txt"
    done
    echo
    echo "**MPI, the studio, one and two ranks pinned to two cores** (\`taskset -c 0,1 mpirun -np N\`, \`--distribution octree\`, 512x512; the render's own time, builds interleaved):"
    echo
    echo "| build | ranks | round | render (s) |"
    echo "| --- | --- | --- | --- |"
    sed -E 's/^([a-z]+) [|] -np ([0-9]+) [|] round ([0-9]+) [|] [(]render ([0-9.]+) s[)]$/| `\1` | \2 | \3 | \4 |/' "$dir/mpi-studio-2cores.txt"
    exit 0
fi

echo "Measured on $(machine) by \`scripts/device-scaling.sh\`; every time a single run unless the table says otherwise."
if [ -f "$dir/threads-studio.txt" ]; then
    echo
    echo "**Threads runtime, the studio** (\`hybrid-rt bench --scene studio --width 512 --height 512 --scaling 1,2,4,8,16 --repeat 3\`):"
    echo
    bench "$dir/threads-studio.txt"
fi
if [ -f "$dir/threads-conference.txt" ]; then
    echo
    echo "**Threads runtime, the conference room** (396 light sources; the same with \`--scene conference --repeat 1\`):"
    echo
    bench "$dir/threads-conference.txt"
fi
if [ -f "$dir/mpi-studio.txt" ]; then
    echo
    echo "**MPI, the studio** from its scene file (\`--distribution octree\`, 512x512; the last six runs pinned to two cores with \`taskset -c 0,1\`):"
    echo
    mpi "$dir/mpi-studio.txt"
fi
for f in "$dir"/mpi-city-*.txt; do
    [ -f "$f" ] || continue
    echo
    echo "**MPI, $(sed -n 's/^city: //p' "$f" | head -1)**, compiled ($(sed -n 's/.*compiled file \([0-9]*\) bytes/\1 bytes/p' "$f")), 128x96 pixels, \`--cache 10%\`:"
    echo
    mpi "$f"
done
