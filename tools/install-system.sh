#!/usr/bin/env bash
# System packages fsivsp's PETSc backend needs (issue 22): Debian's PETSc/petsc4py 3.18 with hypre and MUMPS,
# its mpi4py and Open MPI, and OpenBLAS (on the reference BLAS MUMPS is 8x slower). PyPI has no PETSc wheels.
# Installs them on Debian or Ubuntu as root; elsewhere says in one line how to get petsc4py and returns 0
# (the PETSc backend then reports itself unavailable).
set -euo pipefail
PACKAGES="python3-petsc4py-real python3-slepc4py-real python3-petsc4py-complex python3-slepc4py-complex python3-mpi4py openmpi-bin libopenblas0-serial python3-venv"
installed() { dpkg-query -W -f='${Status}\n' $PACKAGES 2>/dev/null | grep -c 'install ok installed' || true; }
if command -v dpkg-query >/dev/null && [ "$(installed)" -eq "$(echo $PACKAGES | wc -w)" ]; then
    exit 0
fi
if command -v apt-get >/dev/null && [ "$(id -u)" -eq 0 ]; then
    echo "installing Debian packages: $PACKAGES" >&2
    export DEBIAN_FRONTEND=noninteractive
    apt-get update -qq
    apt-get install -y -qq --no-install-recommends $PACKAGES >/dev/null
elif command -v apt-get >/dev/null; then
    echo "petsc4py: run 'sudo apt-get install -y --no-install-recommends $PACKAGES', then make install again" >&2
else
    echo "petsc4py: not installed (no apt-get here); get it from conda-forge ('conda install petsc4py') for the PETSc backend" >&2
fi
