# Source this file (". scripts/env.sh") to use the checkout's venv and ROS workspace in a shell.
_grs_root=$(cd "$(dirname "${BASH_SOURCE[0]:-$0}")/.." && pwd)
. "$_grs_root/.venv/bin/activate"
export AMENT_PREFIX_PATH="$_grs_root/.venv${AMENT_PREFIX_PATH:+:$AMENT_PREFIX_PATH}"
export CMAKE_PREFIX_PATH="$_grs_root/.venv${CMAKE_PREFIX_PATH:+:$CMAKE_PREFIX_PATH}"
if [ -f "$_grs_root/install/setup.bash" ]; then
  # colcon's setup.bash reads unset variables: source it with -u off, restore the caller's -u after
  case $- in *u*) _grs_u=1; set +u ;; *) _grs_u= ;; esac
  # shellcheck disable=SC1091
  . "$_grs_root/install/setup.bash"
  if [ -n "$_grs_u" ]; then set -u; fi
  unset _grs_u
fi
unset _grs_root
