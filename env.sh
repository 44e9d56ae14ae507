# Source this file (bash/zsh): `source ./env.sh`
#
# Gives a shell in the project's environment: the virtual environment
# (.venv, ROS 2 Jazzy from PyPI wheels), the built workspace (install/) and
# the node executables (install/<pkg>/lib/<pkg>/) on PATH; the ROS equivalent
# of sourcing install/setup.bash. Run `make setup` first.

if [ -n "${BASH_SOURCE[0]:-}" ]; then
  _tribo_root="$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)"
else
  _tribo_root="$(cd "$(dirname "$0")" && pwd)"
fi

if [ ! -x "$_tribo_root/.venv/bin/python" ] || [ ! -f "$_tribo_root/install/setup.sh" ]; then
  echo "env.sh: the project is not set up yet; run 'make setup' in $_tribo_root" >&2
  return 1 2>/dev/null || exit 1
fi

export VIRTUAL_ENV="$_tribo_root/.venv"
case ":$PATH:" in *":$VIRTUAL_ENV/bin:"*) ;; *) export PATH="$VIRTUAL_ENV/bin:$PATH" ;; esac
case ":${AMENT_PREFIX_PATH:-}:" in
  *":$VIRTUAL_ENV:"*) ;;
  *) export AMENT_PREFIX_PATH="$VIRTUAL_ENV${AMENT_PREFIX_PATH:+:$AMENT_PREFIX_PATH}" ;;
esac
export RMW_IMPLEMENTATION="${RMW_IMPLEMENTATION:-rmw_fastrtps_cpp}"
# One BLAS thread: the fits call many small linear-algebra routines, where a second
# spinning BLAS thread only takes the other core from the live graph.
export OPENBLAS_NUM_THREADS="${OPENBLAS_NUM_THREADS:-1}" OMP_NUM_THREADS="${OMP_NUM_THREADS:-1}"

# The workspace overlay (PYTHONPATH, LD_LIBRARY_PATH, AMENT_PREFIX_PATH).
# (colcon's setup.sh reads unset variables: relax `set -u` while it runs)
case $- in *u*) _tribo_nounset=1; set +u ;; *) _tribo_nounset= ;; esac
COLCON_CURRENT_PREFIX="$_tribo_root/install"
# shellcheck disable=SC1091
. "$_tribo_root/install/setup.sh"
unset COLCON_CURRENT_PREFIX
[ -n "$_tribo_nounset" ] && set -u
unset _tribo_nounset

# Node executables, as `ros2 run <pkg> <exe>` finds them.
for _tribo_bin in "$_tribo_root"/install/*/lib/tribo_*; do
  [ -d "$_tribo_bin" ] || continue
  case ":$PATH:" in *":$_tribo_bin:"*) ;; *) export PATH="$PATH:$_tribo_bin" ;; esac
done
export TRIBO_ROOT="$_tribo_root"
unset _tribo_root _tribo_bin
