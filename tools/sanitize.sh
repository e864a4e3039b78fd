#!/bin/sh
# The native core under AddressSanitizer + UndefinedBehaviorSanitizer (+ LeakSanitizer), and the
# coverage-guided fuzzer (atheris, whose libFuzzer also sees the core's C edges).
#
#   sh tools/sanitize.sh build            clang build of unbound_core into build/sanitize/ (ASan, UBSan
#                                         that aborts on the first report, libFuzzer coverage hooks)
#   sh tools/sanitize.sh test [ARGS]      the native tests (tests/native) against that build, leaks
#                                         checked at exit; fails on any ASan/UBSan report and on any
#                                         leak whose allocation stack runs through native/src
#   sh tools/sanitize.sh fuzz [ARGS]      tests/fuzz/fuzz_native.py under libFuzzer; ARGS are libFuzzer's
#                                         (e.g. -runs=100000, -max_total_time=180); corpus build/fuzz/corpus,
#                                         crashes saved to build/fuzz/crash-*
#   sh tools/sanitize.sh replay FILES     run the harness once on each input file (a saved crash)
#
# Needs clang (Debian's clang-14: `apt-get install clang`; installed here when missing and root)
# and the project venv (`make venv`); atheris is installed into that venv on first use.
set -eu
cd "$(dirname "$0")/.."
ROOT=$(pwd -P)
PY=${PY:-$ROOT/.venv/bin/python}
OUT=$ROOT/build/sanitize
ATHERIS_VERSION=3.0.0

say() { echo "sanitize: $*" >&2; }
die() { say "error: $*"; exit 1; }

# clang and its sanitizer runtime (Debian ships the runtime as a Recommends of clang).
need_clang() {
	if command -v clang >/dev/null 2>&1 && [ -f "$(clang -print-file-name=libclang_rt.asan-x86_64.so)" ]; then
		return
	fi
	[ "$(id -u)" = 0 ] || die "clang or its sanitizer runtime is missing (apt-get install clang libclang-rt-N-dev)"
	say "installing clang"
	export DEBIAN_FRONTEND=noninteractive
	apt-get update -q >/dev/null
	command -v clang >/dev/null 2>&1 || apt-get install -y -q clang >/dev/null
	[ -f "$(clang -print-file-name=libclang_rt.asan-x86_64.so)" ] ||
		apt-get install -y -q "libclang-rt-$(clang -dumpversion | cut -d. -f1)-dev" >/dev/null
}

need_atheris() {
	"$PY" -c "import atheris" 2>/dev/null || "$PY" -m pip install -q "atheris==$ATHERIS_VERSION"
}

build() {
	need_clang
	inc=$("$PY" -c "import sysconfig; print(sysconfig.get_paths()['include'])")
	# The release build's semantics (setup.py: IEEE, no contraction), plus the sanitizers.
	# -fno-sanitize-recover: a UBSan report aborts, so the fuzzer and the tests see it as a crash.
	# float-divide-by-zero stays off: IEEE division by zero (inf, NaN) is defined and relied on.
	flags="-g -O1 -std=c11 -D_GNU_SOURCE -ffp-contract=off -fno-math-errno -fno-trapping-math -fvisibility=hidden
		-fno-omit-frame-pointer -fPIC -DPy_LIMITED_API=0x030B0000 -Inative/src -I$inc
		-fsanitize=address,undefined,fuzzer-no-link -fno-sanitize-recover=undefined"
	rm -rf "$OUT"
	mkdir -p "$OUT/obj" "$OUT/unbound_core"
	pids=
	for src in native/src/*.c; do
		extra=
		# kernel_avx2.c gets its ISA from `#pragma GCC target`, which clang ignores.
		case $src in *avx2*) extra="-mavx2 -mfma" ;; esac
		# shellcheck disable=SC2086
		clang $flags $extra -c "$src" -o "$OUT/obj/$(basename "$src" .c).o" &
		pids="$pids $!"
	done
	# A bare `wait` returns 0 whatever the compilers did: wait for each and fail with it.
	for pid in $pids; do
		wait "$pid" || die "compiling native/src failed"
	done
	# shellcheck disable=SC2086
	clang -shared -fsanitize=address,undefined,fuzzer-no-link "$OUT"/obj/*.o -lm -lpthread \
		-o "$OUT/unbound_core/_native.abi3.so"
	cp native/unbound_core/*.py "$OUT/unbound_core/"
	say "built $OUT/unbound_core"
}

# The sanitizer runtime comes first in the process (Python itself is not instrumented).
# PYTHONMALLOC=malloc: every Python object through malloc, so LeakSanitizer sees what points to what.
run_sanitized() {
	runtime=$1
	shift
	[ -f "$OUT/unbound_core/_native.abi3.so" ] || build
	env LD_PRELOAD="$runtime" PYTHONMALLOC=malloc UNBOUND_CORE_PATH="$OUT" \
		ASAN_OPTIONS="${ASAN_OPTIONS:-detect_leaks=1:abort_on_error=0:allocator_may_return_null=1:halt_on_error=1}" \
		UBSAN_OPTIONS="${UBSAN_OPTIONS:-print_stacktrace=1:halt_on_error=1}" \
		LSAN_OPTIONS="${LSAN_OPTIONS:-exitcode=0}" \
		"$@"
}

case ${1:-} in
build)
	build
	;;
test)
	shift
	need_clang
	[ -f "$OUT/unbound_core/_native.abi3.so" ] || build
	log=$ROOT/build/sanitize-test.log
	# Timing tests are skipped (UNBOUND_SANITIZED): the sanitizers slow the core several-fold.
	set +e
	# -s: no output capture, so that a sanitizer's report reaches the log even when it ends the
	# process in the middle of a test (captured, it died with the process, unseen).
	run_sanitized "$(clang -print-file-name=libclang_rt.asan-x86_64.so)" env UNBOUND_SANITIZED=1 \
		"$PY" -m pytest -q -s -p no:cacheprovider tests/native "$@" >"$log" 2>&1
	status=$?
	set -e
	# pytest's summary, not LeakSanitizer's exit report that follows it.
	sed '/^=\{20,\}$/,$d' "$log" | tail -n 30
	"$PY" tools/lsan_report.py "$log" || status=1
	# A run that ended without pytest's summary line did not finish, whatever its exit status
	# (the sanitizers' common `exitcode` is 0 here so that leaks at exit are judged by
	# lsan_report.py, and UBSan's halt takes that same code).
	if ! grep -Eq '^[=]* ?[0-9]+ passed' "$log" || grep -Eq '^[=]* ?[0-9]+ failed' "$log"; then
		echo "sanitize: pytest did not finish cleanly (see $log)" >&2
		status=1
	fi
	exit $status
	;;
fuzz)
	shift
	need_atheris
	[ -f "$OUT/unbound_core/_native.abi3.so" ] || build
	mkdir -p build/fuzz/corpus
	atheris_dir=$("$PY" -c "import atheris; print(atheris.path())")
	# Leak detection per input stays off: the interpreter caches objects between inputs, which
	# libFuzzer would count as leaks; `sanitize.sh test` checks leaks of the core at exit.
	ASAN_OPTIONS=${ASAN_OPTIONS:-detect_leaks=0:allocator_may_return_null=1} \
		run_sanitized "$atheris_dir/asan_with_fuzzer.so" "$PY" tests/fuzz/fuzz_native.py \
		-artifact_prefix=build/fuzz/ -rss_limit_mb=4096 -timeout=60 "$@" build/fuzz/corpus tests/fuzz/seeds
	;;
replay)
	shift
	need_atheris
	[ -f "$OUT/unbound_core/_native.abi3.so" ] || build
	atheris_dir=$("$PY" -c "import atheris; print(atheris.path())")
	ASAN_OPTIONS=${ASAN_OPTIONS:-detect_leaks=0:allocator_may_return_null=1} \
		run_sanitized "$atheris_dir/asan_with_fuzzer.so" "$PY" tests/fuzz/fuzz_native.py "$@"
	;;
*)
	sed -n '2,16p' "$0" >&2
	exit 2
	;;
esac
