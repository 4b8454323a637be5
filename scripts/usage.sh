# Sourced (`. "$(dirname "$0")/usage.sh"`) by the scripts whose header
# comment is their usage.
#
# usage: prints the sourcing script's whole header comment (every line after
# the first up to the first that is not a comment) on stderr and exits 2.
usage() {
  awk 'NR > 1 && !/^#/ { exit } NR > 1' "$0" >&2
  exit 2
}
