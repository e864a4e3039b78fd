#!/bin/sh
# The README's fresh-machine promise, tested: a bare Debian root (debootstrap minbase) with only what
# the README names (Python, make, a C compiler; ca-certificates for HTTPS), a copy of this working
# tree, and `make demo` run in it as a new user would, as root. check_system.sh must install the
# rest (pythonX.Y-venv, pythonX.Y-dev, bpy's X11/GL libraries), the venv must build from the pinned
# requirements, and the demo must render its frames through Blender's pipeline and print their paths.
#
#   sh tools/fresh_root.sh [bookworm|trixie] [--keep]
#
# bookworm (Debian 12): python3.11 -> bpy 4.2 LTS.  trixie (Debian 13): python3.13 -> bpy 5.2.
# Before `make demo`, check_system.sh also runs as an unprivileged user there and must stop with the
# `sudo apt-get install ...` line. The root is built from scratch every time (nothing cached) and
# removed afterwards unless --keep. Needs root (debootstrap, chroot) and network access to
# deb.debian.org and PyPI; about 6-10 minutes, most of it downloads (bpy is 300-400 MB) and the build.
#
# Env: FRESH_ROOT_DIR (default /var/tmp/unbound-fresh; the root is $FRESH_ROOT_DIR/<suite>),
#      DEBIAN_MIRROR (default http://deb.debian.org/debian), FRESH_MAKE (default "demo").
set -eu

SUITE=bookworm
KEEP=
for a in "$@"; do
	case $a in
	bookworm | trixie) SUITE=$a ;;
	--keep) KEEP=1 ;;
	*) echo "usage: sh $0 [bookworm|trixie] [--keep]" >&2; exit 2 ;;
	esac
done
case $SUITE in
bookworm) PYPKG=python3.11 ;;
trixie) PYPKG=python3.13 ;;
esac
BASE=${FRESH_ROOT_DIR:-/var/tmp/unbound-fresh}
R=$BASE/$SUITE
MIRROR=${DEBIAN_MIRROR:-http://deb.debian.org/debian}
TARGET=${FRESH_MAKE:-demo}
SRC=/srv/unbound            # the repository inside the root (readable by the unprivileged check)
CA=/etc/ssl/certs/ca-certificates.crt

say() { echo "fresh_root[$SUITE]: $*" >&2; }
die() { say "error: $*"; exit 1; }
now() { date +%s; }
T0=$(now)
lap() { say "$1: $(($(now) - $2)) s"; }

[ "$(id -u)" = 0 ] || die "needs root (debootstrap, chroot)"
HERE=$(cd "$(dirname "$0")/.." && pwd -P)
command -v git >/dev/null || die "needs git (to copy the working tree's files)"

# Refuse to delete a root something is still mounted in (inroot's mounts die with its namespace).
unmounted() {
	! grep -q " $1[/ ]" /proc/self/mountinfo
}
remove_root() {
	[ -e "$R" ] || return 0
	unmounted "$R" || die "something is mounted under $R; not removing it"
	rm -rf "$R"
}

# inroot CMD...: CMD inside the root, in private pid+mount namespaces (/proc, /dev/pts, /dev/shm
# vanish with it), with a clean environment as a login would give, cwd $SRC.
inroot() {
	unshare --fork --pid --mount --propagation private --kill-child sh -euc '
		R=$1; shift
		mount -t proc proc "$R/proc"
		[ -c "$R/dev/null" ] || mount --rbind /dev "$R/dev"
		mount -t devpts -o newinstance,ptmxmode=0666 devpts "$R/dev/pts" 2>/dev/null || :
		[ ! -d "$R/dev/shm" ] || mount -t tmpfs -o mode=1777 shm "$R/dev/shm" 2>/dev/null || :
		exec chroot "$R" /usr/bin/env -i -C "$0" "$@"
	' "$SRC" "$R" \
		PATH=/usr/local/sbin:/usr/local/bin:/usr/sbin:/usr/bin:/sbin:/bin \
		HOME=/root LANG=C.UTF-8 TERM=dumb \
		PIP_DISABLE_PIP_VERSION_CHECK=1 PIP_NO_CACHE_DIR=1 PIP_DEFAULT_TIMEOUT=180 \
		PIP_CERT=$CA SSL_CERT_FILE=$CA REQUESTS_CA_BUNDLE=$CA \
		"$@"
}

# -- the bare root ------------------------------------------------------------------------------------
if ! command -v debootstrap >/dev/null; then
	say "installing debootstrap on the host"
	DEBIAN_FRONTEND=noninteractive apt-get update -qq && DEBIAN_FRONTEND=noninteractive \
		apt-get install -y -qq debootstrap >/dev/null || die "could not install debootstrap"
fi
mkdir -p "$BASE"
remove_root
t=$(now)
say "debootstrap --variant=minbase $SUITE with $PYPKG make gcc ca-certificates into $R"
debootstrap --variant=minbase --include="$PYPKG,make,gcc,ca-certificates" "$SUITE" "$R" "$MIRROR" \
	>"$R.debootstrap.log" 2>&1 || {
	tail -n 20 "$R.debootstrap.log" >&2
	die "debootstrap failed (log: $R.debootstrap.log)"
}
rm -f "$R.debootstrap.log"
lap "bare root built" "$t"
[ "$KEEP" ] || trap 'remove_root' EXIT
mkdir -p "$R$SRC"

# As on an installed system (Blender reads the mounted file systems from it).
[ -e "$R/etc/mtab" ] || ln -s ../proc/self/mounts "$R/etc/mtab"
# Network, as on any machine: DNS, and the host's extra CA certificates (a TLS-inspecting proxy's;
# without them pip fails with CERTIFICATE_VERIFY_FAILED).
cp -L /etc/resolv.conf "$R/etc/resolv.conf"
mkdir -p "$R/usr/local/share/ca-certificates"
for c in /usr/local/share/ca-certificates/*.crt; do
	[ ! -f "$c" ] || cp "$c" "$R/usr/local/share/ca-certificates/"
done
inroot update-ca-certificates >/dev/null 2>&1 || die "update-ca-certificates failed"

# The working tree's files as a clone would have them (tracked and untracked-but-not-ignored; no
# .venv, build/, dist/, out/), readable by everyone like a clone in a home directory.
(cd "$HERE" && git ls-files -z --cached --others --exclude-standard |
	xargs -0 sh -c 'for f; do [ -f "$f" ] && printf "%s\0" "$f"; done' sh |
	tar --null -T - -cf -) | tar -xf - -C "$R$SRC"
chmod -R a+rX "$R$SRC"
inroot apt-get clean
say "bare root: $(inroot sh -c '. /etc/os-release; echo "$PRETTY_NAME"'), $(inroot "$PYPKG" --version 2>&1), $(du -sm --exclude="$R$SRC" "$R" | cut -f1) MB"

# -- as a user without root: the check must stop and name the one command ---------------------------
set +e
msg=$(inroot setpriv --reuid=65534 --regid=65534 --clear-groups sh tools/check_system.sh 2>&1 >/dev/null)
rc=$?
set -e
printf '%s\n' "$msg" | sed 's/^/  | /' >&2
[ $rc != 0 ] || die "check_system.sh passed as a user on a bare root"
printf '%s\n' "$msg" | grep -q "sudo apt-get update && sudo apt-get install -y --no-install-recommends .*$PYPKG-venv .*$PYPKG-dev .*libx11-6" ||
	die "check_system.sh did not print the sudo apt-get line"

# -- as root: make demo installs what it needs and renders ------------------------------------------
t=$(now)
say "make $TARGET (as root, clean environment)"
set +e
inroot make "$TARGET" >"$R.make.log" 2>&1
rc=$?
set -e
sed 's/^/  | /' "$R.make.log" >&2
lap "make $TARGET" "$t"
[ $rc = 0 ] || die "make $TARGET failed ($rc)"

if [ "$TARGET" = demo ]; then
	png=$(ls "$R$SRC"/out/animate_mu/png/*.png 2>/dev/null | wc -l)
	exr=$(ls "$R$SRC"/out/animate_mu/exr/*.exr 2>/dev/null | wc -l)
	say "frames written: $png PNG, $exr EXR"
	[ "$png" -ge 1 ] && [ "$png" = "$exr" ] || die "the demo wrote no frames"
	grep -q "$SRC/out/animate_mu/png/" "$R.make.log" || die "the demo did not print the paths of its frames"
	inroot .venv/bin/python -c 'import sys, bpy; print("fresh_root: Python", sys.version.split()[0], "bpy", bpy.app.version_string)' 2>&1 | tail -n 1 >&2
	inroot apt-get clean
	say "disk after apt-get clean: root $(du -sm --exclude="$R$SRC" "$R" | cut -f1) MB, .venv $(du -sm "$R$SRC/.venv" | cut -f1) MB"
fi
rm -f "$R.make.log"
lap "total" "$T0"
[ -z "$KEEP" ] || say "kept: $R (remove it with: rm -rf $R)"
