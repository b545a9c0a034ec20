#!/usr/bin/env bash
# Proves the README's quick start on a machine that has never seen shadefit: builds a minimal
# Debian 12 root (mmdebstrap --variant=minbase, or debootstrap), puts a clean clone of this
# repository and ../shared into it, and runs BOTH README commands inside it with chroot, as
# root, with nothing installed but the minimal base:
#   bash scripts/bootstrap.sh main   must print the report's path, and that report must exist;
#   bash scripts/bootstrap.sh test   must pass.
# It prints the time of each phase, and removes the root (unmounting what it mounted) on
# success, failure and Ctrl-C alike.
#
#   bash scripts/fresh-machine-check.sh [--rev REV] [--shared DIR] [--no-cache] [--keep]
#                                       [--reuse-pass] [--has-pass] [--logs DIR]
#
#   --rev REV      commit to clone (default HEAD; uncommitted changes are not part of a check)
#   --reuse-pass   skip the check when one passed on this machine for the same install inputs
#                  (bootstrap.sh, check-skips.py, this script, every CMakeLists.txt and cmake/
#                  file, the CI skip list, at REV); .ci/run uses it (docs/testing.md says what
#                  that costs)
#   --has-pass     only say whether such a pass is recorded (exit 0) or not (exit 1); .ci/run
#                  asks before choosing where to run the README's test command
#   --logs DIR     copy the two commands' output (main.log, test.log: together one full build's
#                  log, for scripts/check-warnings.sh) to DIR, on success and failure alike
#   --shared DIR   the folder that sits beside the clone as ../shared (default: ../shared)
#   --no-cache     build the base root afresh instead of reusing the cached minbase tarball
#   --keep         leave the root in place afterwards (for debugging; prints where)
#
# The minbase root (no project package in it, ever) is cached as a tarball under
# $SHADEFIT_ROOT_CACHE (default /var/cache/shadefit-fresh-root) and refreshed after 7 days; the
# packages the project installs are never cached: the README's own command installs them.
# The root uses this machine's apt sources, apt proxy settings and DNS configuration, so it
# reaches the same package mirror. Needs root (chroot, mount).
set -euo pipefail

say() { printf 'fresh-machine-check: %s\n' "$*"; }
die() { printf 'fresh-machine-check: error: %s\n' "$*" >&2; exit 1; }

repo=$(cd "$(dirname "$0")/.." && pwd)
rev=HEAD
shared="$repo/../shared"
use_cache=1
keep=0
reuse_pass=0
has_pass=0
logs_dir=""
while [ $# -gt 0 ]; do
  case "$1" in
    --rev) rev=${2:?--rev needs a commit}; shift 2 ;;
    --shared) shared=${2:?--shared needs a folder}; shift 2 ;;
    --no-cache) use_cache=0; shift ;;
    --keep) keep=1; shift ;;
    --reuse-pass) reuse_pass=1; shift ;;
    --has-pass) has_pass=1; shift ;;
    --logs) logs_dir=${2:?--logs needs a folder}; shift 2 ;;
    -h | --help) sed -n '2,31p' "$0"; exit 0 ;;
    *) die "unknown option '$1' (see --help)" ;;
  esac
done
[ "$(id -u)" -eq 0 ] || die "must run as root (it uses chroot and mount)"
command -v chroot >/dev/null || die "chroot not found (coreutils)"
git -C "$repo" rev-parse --verify -q "$rev^{commit}" >/dev/null || die "$repo: no commit '$rev'"

# What decides whether the README's commands install and build on a fresh machine: a pass for
# the same bytes of these files is recorded under the cache folder and reused by --reuse-pass.
pass_dir=${SHADEFIT_ROOT_CACHE:-/var/cache/shadefit-fresh-root}/passed
pass_key=$(git -C "$repo" ls-tree -r "$rev" -- scripts/bootstrap.sh scripts/check-skips.py \
             scripts/fresh-machine-check.sh \
             cmake tests/ci-allowed-skips.txt $(git -C "$repo" ls-tree -r --name-only "$rev" |
             grep -E '(^|/)CMakeLists\.txt$') | sha256sum | cut -c1-16)
if [ "$has_pass" = 1 ]; then
  if [ -f "$pass_dir/$pass_key" ]; then
    say "passed before on this machine for these install inputs ($(cat "$pass_dir/$pass_key"))"
    exit 0
  fi
  say "no pass recorded on this machine for these install inputs"
  exit 1
fi
if [ "$reuse_pass" = 1 ] && [ -f "$pass_dir/$pass_key" ]; then
  say "passed before on this machine for these install inputs ($(cat "$pass_dir/$pass_key")); skipped"
  say "(run without --reuse-pass to check again)"
  exit 0
fi

# --- phase timing --------------------------------------------------------------------------
declare -a phase_names=() phase_secs=()
phase_start=0
phase_name=""
begin() { phase_name=$1; phase_start=$(date +%s); say "== $1"; }
end() {
  local s=$(( $(date +%s) - phase_start ))
  phase_names+=("$phase_name"); phase_secs+=("$s")
  say "   $phase_name: ${s} s"
}
summary() {
  local i
  for i in "${!phase_names[@]}"; do
    printf 'fresh-machine-check: %-34s %5d s\n' "${phase_names[$i]}" "${phase_secs[$i]}"
  done
}

# --- the root, and cleaning it up whatever happens ------------------------------------------
work=$(mktemp -d /var/tmp/shadefit-fresh-root.XXXXXX)
root="$work/root"
mounted=()
cleanup() {
  local rc=$?
  trap - EXIT INT TERM
  local m
  if [ -n "$logs_dir" ]; then
    mkdir -p "$logs_dir"
    for m in main.log test.log; do [ -f "$work/$m" ] && cp "$work/$m" "$logs_dir/$m"; done
  fi
  for ((i = ${#mounted[@]} - 1; i >= 0; i--)); do
    m=${mounted[$i]}
    umount -R "$m" 2>/dev/null || umount -lR "$m" 2>/dev/null || true
  done
  if [ "$keep" -eq 1 ] && [ "$rc" -ne 130 ]; then
    say "root kept at $root"
  else
    # Never follow a mount that failed to go away into the host's /proc, /dev or /sys.
    if ! grep -q " $root/" /proc/mounts; then rm -rf --one-file-system "$work"; fi
  fi
  exit "$rc"
}
trap cleanup EXIT
trap 'say "interrupted"; exit 130' INT TERM

# --- 1. tools on the host -------------------------------------------------------------------
begin "host tools"
maker=""
if command -v mmdebstrap >/dev/null; then maker=mmdebstrap
elif command -v debootstrap >/dev/null; then maker=debootstrap
else
  say "installing mmdebstrap (a Debian package) on the host to build the root"
  if ! DEBIAN_FRONTEND=noninteractive apt-get install -y -qq --no-install-recommends \
       mmdebstrap >/dev/null 2>"$work/apt-host.log"; then
    DEBIAN_FRONTEND=noninteractive apt-get update -qq >/dev/null 2>&1 || true
    DEBIAN_FRONTEND=noninteractive apt-get install -y -qq --no-install-recommends \
      mmdebstrap >/dev/null 2>"$work/apt-host.log" ||
      die "cannot install mmdebstrap on the host (no Debian mirror reachable?): $(tail -n1 "$work/apt-host.log")"
  fi
  maker=mmdebstrap
fi
end

# The host's apt sources (one-line or deb822) and proxy settings, for the root to use.
sources="$work/sources.list"
: >"$sources"
[ -f /etc/apt/sources.list ] && grep -E '^[[:space:]]*deb ' /etc/apt/sources.list >>"$sources" || true
for f in /etc/apt/sources.list.d/*.list; do
  [ -f "$f" ] && grep -E '^[[:space:]]*deb ' "$f" >>"$sources" || true
done
# deb822 files: turn each stanza with Types: deb and a Debian suite into one-line entries.
for f in /etc/apt/sources.list.d/*.sources; do
  [ -f "$f" ] || continue
  awk '
    function flush() {
      if (types ~ /(^| )deb( |$)/ && uris != "" && suites != "")
        { n = split(uris, u, " "); m = split(suites, s, " ");
          for (i = 1; i <= n; i++) for (j = 1; j <= m; j++) print "deb " u[i] " " s[j] " " comps }
      types = uris = suites = comps = ""; enabled = 1 }
    BEGIN { enabled = 1 }
    /^[[:space:]]*$/ { flush(); next }
    /^#/ { next }
    tolower($1) == "types:" { $1 = ""; types = substr($0, 2) }
    tolower($1) == "uris:" { $1 = ""; uris = substr($0, 2) }
    tolower($1) == "suites:" { $1 = ""; suites = substr($0, 2) }
    tolower($1) == "components:" { $1 = ""; comps = substr($0, 2) }
    tolower($1) == "enabled:" && tolower($2) == "no" { types = "" }
    END { flush() }' "$f" >>"$sources"
done
grep -qE 'bookworm([[:space:]]|$)' "$sources" || echo "deb http://deb.debian.org/debian bookworm main" >>"$sources"
proxy_conf="$work/90-host-proxy.conf"
apt-config dump 2>/dev/null | grep -iE '^Acquire::(http|https|ftp)::Proxy' >"$proxy_conf" || true
aptopts=()
while IFS= read -r line; do aptopts+=(--aptopt="$line"); done <"$proxy_conf"

# --- 2. the minimal Debian 12 root ----------------------------------------------------------
cache_dir=${SHADEFIT_ROOT_CACHE:-/var/cache/shadefit-fresh-root}
cache="$cache_dir/bookworm-minbase-$maker.tar"
begin "base root ($maker, minbase)"
mkdir -p "$root"
fresh_cache=0
if [ "$use_cache" -eq 1 ] && [ -f "$cache" ] && tar -tf "$cache" ./etc/debian_version >/dev/null 2>&1 \
    && [ -n "$(find "$cache" -mtime -7)" ]; then
  say "reusing the cached minimal base $cache ($(du -h "$cache" | cut -f1))"
else
  fresh_cache=1
fi
if [ "$fresh_cache" -eq 1 ]; then
  mkdir -p "$cache_dir"
  tmp_tar="$cache_dir/.building.$$.tar"  # mmdebstrap picks the format from the name
  if [ "$maker" = mmdebstrap ]; then
    if ! mmdebstrap --quiet --variant=minbase --format=tar "${aptopts[@]}" bookworm "$tmp_tar" "$sources" \
         >"$work/root-build.log" 2>&1; then
      rm -f "$tmp_tar"
      die "cannot build a Debian 12 root with mmdebstrap (no mirror reachable?): $(grep -iE 'error|fail' "$work/root-build.log" | tail -n1)"
    fi
  else
    mirror=$(awk '$3 == "bookworm" { print $2; exit }' "$sources")
    if ! debootstrap --variant=minbase bookworm "$work/dbs" "$mirror" >"$work/root-build.log" 2>&1; then
      die "cannot build a Debian 12 root with debootstrap from $mirror (no mirror reachable?): $(tail -n1 "$work/root-build.log")"
    fi
    tar -C "$work/dbs" -cf "$tmp_tar" . && rm -rf --one-file-system "$work/dbs"
  fi
  mv -f "$tmp_tar" "$cache"
fi
tar -C "$root" -xf "$cache"
cp "$sources" "$root/etc/apt/sources.list"
rm -f "$root"/etc/apt/sources.list.d/*.sources "$root"/etc/apt/sources.list.d/*.list
[ -s "$proxy_conf" ] && cp "$proxy_conf" "$root/etc/apt/apt.conf.d/90-host-proxy.conf"
cp -L /etc/resolv.conf "$root/etc/resolv.conf" 2>/dev/null || true
# A minbase root has no /etc/hosts (no package ships it: on a real machine the Debian installer,
# cloud-init or the container runtime writes it), so 'localhost' does not resolve there, and
# whatever talks to a local service by that name fails: selenium polls chromedriver at
# localhost:<port> and gave up with "Can not connect to the Service /usr/bin/chromedriver" (the
# report_browser failure of 2026-12-01). Write the file the Debian installer (netcfg) writes.
if [ ! -e "$root/etc/hosts" ]; then
  printf '127.0.0.1\tlocalhost\n127.0.1.1\t%s\n\n::1\tlocalhost ip6-localhost ip6-loopback\nff02::1\tip6-allnodes\nff02::2\tip6-allrouters\n' \
    "$(uname -n)" >"$root/etc/hosts"
fi
for p in build-essential cmake libceres-dev; do
  if chroot "$root" dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed"; then
    die "the base root already has $p: it is not a fresh machine"
  fi
done
say "base root: $(du -sh --one-file-system "$root" | cut -f1), $(chroot "$root" dpkg-query -W | wc -l) packages"
end

# --- 3. a clean clone and ../shared ---------------------------------------------------------
begin "clean clone and ../shared"
mkdir -p "$root/work"
git clone -q --no-hardlinks "$repo" "$root/work/main"
git -C "$root/work/main" checkout -q --detach "$rev"
if [ -d "$shared" ]; then
  # Its files, not its links: ../shared may itself be a link (a CI checkout's), or hold links,
  # whose targets are outside the root (copied as links, /work/shared was a link to itself in
  # the root, and every test that needs the data skipped).
  mkdir -p "$root/work/shared"
  cp -RL --preserve=mode,timestamps "$shared/." "$root/work/shared/"
  say "../shared copied from $(cd "$shared" && pwd -P) ($(du -sh "$root/work/shared" | cut -f1))"
else
  say "no $shared: the measured-material part runs without it (as for a newcomer)"
fi
# Debian's convention for chroots: packages' maintainer scripts start no daemon (munge's would
# run on in the host's process table after the check and keep the root's mounts busy).
printf '#!/bin/sh\nexit 101\n' >"$root/usr/sbin/policy-rc.d"
chmod 755 "$root/usr/sbin/policy-rc.d"
for m in proc sys dev; do
  mkdir -p "$root/$m"
  mount --rbind "/$m" "$root/$m"
  mount --make-rslave "$root/$m"
  mounted+=("$root/$m")
done
mkdir -p "$root/tmp" && chmod 1777 "$root/tmp"
end

in_root() {
  # A login-like environment: nothing from this shell's build or Python set-up leaks in.
  chroot "$root" /usr/bin/env -i HOME=/root TERM=dumb LANG=C.UTF-8 \
    PATH=/usr/local/sbin:/usr/local/bin:/usr/sbin:/usr/bin:/sbin:/bin \
    ${CI:+CI=$CI} /bin/bash -c "$1"
}

# --- 4. README command 1: bootstrap main ----------------------------------------------------
begin "README command 1 (bootstrap.sh main)"
main_log="$work/main.log"
if ! in_root 'cd /work/main && bash scripts/bootstrap.sh main' 2>&1 | tee "$main_log"; then
  say "the README's first command failed on a fresh root; last lines:"
  tail -n 20 "$main_log" | sed 's/^/  | /'
  die "bash scripts/bootstrap.sh main failed on a fresh Debian 12 root"
fi
report=$(grep -E '/index\.html$' "$main_log" | tail -n1 || true)
[ -n "$report" ] || die "bash scripts/bootstrap.sh main did not print the report's path"
case "$report" in /*) report_in_root="$root$report" ;; *) report_in_root="$root/work/main/$report" ;; esac
[ -s "$report_in_root" ] || die "the report it printed, $report, does not exist in the root"
grep -q '<table' "$report_in_root" || die "the report $report has no table in it"
say "report written: $report ($(du -h "$report_in_root" | cut -f1))"
end

# --- 5. README command 2: bootstrap test ----------------------------------------------------
begin "README command 2 (bootstrap.sh test)"
test_log="$work/test.log"
if ! in_root 'cd /work/main && bash scripts/bootstrap.sh test' >"$test_log" 2>&1; then
  say "the README's test command failed on a fresh root; last lines:"
  tail -n 40 "$test_log" | sed 's/^/  | /'
  die "bash scripts/bootstrap.sh test failed on a fresh Debian 12 root"
fi
grep -E 'tests passed|tests failed' "$test_log" | tail -n1 | sed 's/^/fresh-machine-check:    /'
end

say "== both README commands passed on a fresh Debian 12 root"
mkdir -p "$pass_dir"
echo "$(git -C "$repo" rev-parse --short "$rev"), $(date -u +%Y-%m-%dT%H:%MZ)" >"$pass_dir/$pass_key"
summary
