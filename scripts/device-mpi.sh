# Sourced by the device scripts (scripts/device-scaling.sh,
# scripts/device-compare.sh): Open MPI ready to run as root on one machine.
# Where no mpirun is found and MPI_TAR names a tar.xz of Debian's Open MPI
# files, they are unpacked into / without overwriting anything there. WORK
# is the caller's scratch folder.
if [ -n "${MPI_TAR:-}" ] && ! command -v mpirun >/dev/null; then
    mkdir -p "$WORK/mpiroot"
    tar -C "$WORK/mpiroot" -xJf "$MPI_TAR"
    cp -rn "$WORK/mpiroot"/. / 2>/dev/null
    ldconfig
    ln -sf /usr/bin/orterun /usr/local/bin/mpirun
fi
export OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1
export OMPI_MCA_mca_base_component_show_load_errors=0
export OMPI_MCA_btl=self,vader OMPI_MCA_pml=ob1
export OMPI_MCA_btl_vader_single_copy_mechanism=none
