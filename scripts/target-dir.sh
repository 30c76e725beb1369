# shellcheck shell=sh
# Sourced, not run: sets `target` to cargo's target directory for the repository the script was
# started in, as an absolute path.
#
#   . "$root/scripts/target-dir.sh"      # after cd to the repository root
#   bin=$target/release/ftpd3d
#
# Cargo builds into ./target unless CARGO_TARGET_DIR or a `build.target-dir` in a
# .cargo/config.toml (the repository's, the user's) says otherwise, and a relative
# CARGO_TARGET_DIR is read from the directory cargo starts in. `cargo metadata` applies all of
# these rules, so the scripts ask it instead of assuming ./target (a common habit is one shared
# target directory for all checkouts). `--no-deps` reads only the manifests: no network, well
# under a second.
target=$(cargo metadata --format-version 1 --no-deps 2>/dev/null |
  sed -n 's/.*"target_directory":"\([^"]*\)".*/\1/p' || :)
if [ -z "$target" ]; then
  echo "$(basename "$0"): cannot find cargo's target directory (\`cargo metadata\` failed in $PWD)" >&2
  exit 2
fi
