#!/usr/bin/env bash
# The project's one test command (README "Run the tests"; .ci/run calls it).
# The default build needs nothing system-wide (everything comes from
# crates.io). The MPI runtime (feature `mpi`) needs Open MPI and libclang:
# installed here with apt-get when missing (as root; otherwise install
# libopenmpi-dev openmpi-bin libclang-dev yourself, or set SKIP_MPI=1 to
# leave the MPI checks out locally).
set -euo pipefail
cd "$(dirname "$0")/.."

export CARGO_TERM_COLOR="${CARGO_TERM_COLOR:-never}"
echo "== rustfmt"
cargo fmt --all --check
echo "== clippy"
cargo clippy --workspace --all-targets --locked -- -D warnings
echo "== API docs (rustdoc, warnings denied; open target/doc/hybrid_sched/index.html)"
RUSTDOCFLAGS="${RUSTDOCFLAGS:-} -D warnings" cargo doc --workspace --no-deps --locked
# mdBook, pinned, built from crates.io into target/tools (no root needed,
# kept with the build cache) unless that version is on the PATH already.
MDBOOK_VERSION=0.5.4
export PATH="$PWD/target/tools/bin:$PATH"
echo "== book (mdBook $MDBOOK_VERSION; open book/book/index.html)"
if [ "$(mdbook --version 2>/dev/null)" != "mdbook v$MDBOOK_VERSION" ]; then
    echo "installing mdbook $MDBOOK_VERSION into target/tools"
    cargo install mdbook --locked --version "$MDBOOK_VERSION" \
        --no-default-features --features search --root target/tools
fi
book_log="$(mdbook build book 2>&1)" || { echo "$book_log" >&2; exit 1; }
echo "$book_log"
if grep -qE '^ *(WARN|ERROR)' <<<"$book_log"; then
    echo "error: mdbook warned (see above)" >&2
    exit 1
fi
echo "== tests (workspace: unit, integration, doctests incl. the book)"
cargo test --workspace --locked
echo "== Radiance's regression scenes against its reference images (release build)"
cargo test --release --locked -p hybrid-rt --test radiance_suite
echo "== concave seams at scene scales 1e-5..1e5 (release build)"
cargo test --release --locked -p hybrid-rt --test seams
echo "== committed experiment outputs equal what the code writes (release build)"
cargo test --release --locked -p hybrid-rt --test experiments_committed

if [ "${SKIP_MPI:-0}" = 1 ]; then
    echo "== MPI checks skipped (SKIP_MPI=1)"
    exit 0
fi

MPI_PACKAGES=(libopenmpi-dev openmpi-bin libclang-dev)
mpi_installed() {
    command -v mpirun >/dev/null 2>&1 &&
        dpkg-query -W -f='${Status}\n' "${MPI_PACKAGES[@]}" 2>/dev/null |
        grep -c '^install ok installed$' | grep -qx "${#MPI_PACKAGES[@]}"
}
echo "== MPI: Open MPI and libclang"
if mpi_installed; then
    echo "already installed: ${MPI_PACKAGES[*]}"
else
    if [ "$(id -u)" != 0 ] || ! command -v apt-get >/dev/null 2>&1; then
        echo "error: the MPI checks need ${MPI_PACKAGES[*]} (Debian packages);" \
            "install them as root, or set SKIP_MPI=1 to skip these checks" >&2
        exit 1
    fi
    export DEBIAN_FRONTEND=noninteractive
    if ! { apt-get update -q && apt-get install -y -q --no-install-recommends "${MPI_PACKAGES[@]}"; }; then
        echo "error: could not install ${MPI_PACKAGES[*]} with apt-get" >&2
        exit 1
    fi
    mpi_installed || { echo "error: ${MPI_PACKAGES[*]} still missing after apt-get" >&2; exit 1; }
fi
mpirun --version | head -n 1

echo "== clippy (feature mpi)"
cargo clippy -p hybrid-sched -p hybrid-rt --features hybrid-sched/mpi,hybrid-rt/mpi \
    --all-targets --locked -- -D warnings
echo "== tests (feature mpi: wire format, mpirun -np 1/2/4 --oversubscribe)"
export OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1
cargo test -p hybrid-sched --features mpi --locked --lib runtime::mpi
cargo test -p hybrid-rt --features mpi --locked --test mpi
