/* What differs between the platforms Blender runs on (Windows, macOS, Linux; x86-64 and arm64),
 * in one place: threads, a mutex, a condition variable with a relative timeout, a monotonic
 * clock, the CPU count, the CPU's SIMD features and the floating-point mode of the kernels.
 * Everything else in the core is plain C11 plus GCC/Clang's __atomic builtins. */
#ifndef UNBOUND_PORT_H
#define UNBOUND_PORT_H

#if !defined(__GNUC__)
/* __atomic builtins, vector pragmas and inline asm: GCC or Clang (zig cc, Apple clang, clang-cl). */
#error "the Unbound core builds with GCC or Clang"
#endif

#include <stdint.h>

#if defined(__x86_64__) || defined(_M_X64)
#define UB_X86_64 1
#include <cpuid.h>
#include <immintrin.h>
#elif defined(__aarch64__) || defined(_M_ARM64)
#define UB_ARM64 1
#endif

/* ---- threads, mutex, condition variable ------------------------------------------------- */
#if defined(_WIN32)
#ifndef WIN32_LEAN_AND_MEAN
#define WIN32_LEAN_AND_MEAN
#endif
#include <windows.h>

typedef HANDLE ub_thread;
typedef SRWLOCK ub_mutex;
typedef CONDITION_VARIABLE ub_cond;
/* A thread's entry point: UB_THREAD_ENTRY(name, arg) { ...; UB_THREAD_RETURN; } */
#define UB_THREAD_ENTRY(name, arg) static DWORD WINAPI name(LPVOID arg)
#define UB_THREAD_RETURN return 0
typedef DWORD(WINAPI *ub_thread_entry)(LPVOID);

static inline int ub_thread_start(ub_thread *t, ub_thread_entry entry, void *arg)
{
    *t = CreateThread(NULL, 0, entry, arg, 0, NULL);
    return *t != NULL;
}
static inline void ub_thread_join(ub_thread t)
{
    WaitForSingleObject(t, INFINITE);
    CloseHandle(t);
}
/* The thread runs on and cleans up after itself; nobody joins it. */
static inline void ub_thread_detach(ub_thread t) { CloseHandle(t); }
static inline void ub_sleep_ms(int ms) { Sleep((DWORD)ms); }
static inline void ub_mutex_init(ub_mutex *m) { InitializeSRWLock(m); }
static inline void ub_mutex_destroy(ub_mutex *m) { (void)m; }
static inline void ub_mutex_lock(ub_mutex *m) { AcquireSRWLockExclusive(m); }
static inline void ub_mutex_unlock(ub_mutex *m) { ReleaseSRWLockExclusive(m); }
static inline void ub_cond_init(ub_cond *c) { InitializeConditionVariable(c); }
static inline void ub_cond_destroy(ub_cond *c) { (void)c; }
static inline void ub_cond_signal(ub_cond *c) { WakeConditionVariable(c); }
static inline void ub_cond_broadcast(ub_cond *c) { WakeAllConditionVariable(c); }
static inline void ub_cond_wait(ub_cond *c, ub_mutex *m) { SleepConditionVariableSRW(c, m, INFINITE, 0); }
/* Waits at most `ns` nanoseconds (rounded up to whole milliseconds, Windows' unit). */
static inline void ub_cond_wait_ns(ub_cond *c, ub_mutex *m, int64_t ns)
{
    SleepConditionVariableSRW(c, m, (DWORD)((ns + 999999) / 1000000), 0);
}
#else
#include <pthread.h>
#include <time.h>
#include <unistd.h>

typedef pthread_t ub_thread;
typedef pthread_mutex_t ub_mutex;
typedef pthread_cond_t ub_cond;
#define UB_THREAD_ENTRY(name, arg) static void *name(void *arg)
#define UB_THREAD_RETURN return NULL
typedef void *(*ub_thread_entry)(void *);

static inline int ub_thread_start(ub_thread *t, ub_thread_entry entry, void *arg)
{
    return pthread_create(t, NULL, entry, arg) == 0;
}
static inline void ub_thread_join(ub_thread t) { pthread_join(t, NULL); }
static inline void ub_thread_detach(ub_thread t) { pthread_detach(t); }
static inline void ub_sleep_ms(int ms)
{
    struct timespec ts = {ms / 1000, (long)(ms % 1000) * 1000000L};
    nanosleep(&ts, NULL);
}
static inline void ub_mutex_init(ub_mutex *m) { pthread_mutex_init(m, NULL); }
static inline void ub_mutex_destroy(ub_mutex *m) { pthread_mutex_destroy(m); }
static inline void ub_mutex_lock(ub_mutex *m) { pthread_mutex_lock(m); }
static inline void ub_mutex_unlock(ub_mutex *m) { pthread_mutex_unlock(m); }
static inline void ub_cond_destroy(ub_cond *c) { pthread_cond_destroy(c); }
static inline void ub_cond_signal(ub_cond *c) { pthread_cond_signal(c); }
static inline void ub_cond_broadcast(ub_cond *c) { pthread_cond_broadcast(c); }
static inline void ub_cond_wait(ub_cond *c, ub_mutex *m) { pthread_cond_wait(c, m); }
#if defined(__APPLE__)
/* macOS has no pthread_condattr_setclock, but a wait with a relative timeout. */
static inline void ub_cond_init(ub_cond *c) { pthread_cond_init(c, NULL); }
static inline void ub_cond_wait_ns(ub_cond *c, ub_mutex *m, int64_t ns)
{
    struct timespec rel = {(time_t)(ns / 1000000000), (long)(ns % 1000000000)};
    pthread_cond_timedwait_relative_np(c, m, &rel);
}
#else
/* The deadline on the monotonic clock, so that a change of the wall clock cannot stall a poll. */
static inline void ub_cond_init(ub_cond *c)
{
    pthread_condattr_t attr;
    pthread_condattr_init(&attr);
    pthread_condattr_setclock(&attr, CLOCK_MONOTONIC);
    pthread_cond_init(c, &attr);
    pthread_condattr_destroy(&attr);
}
static inline void ub_cond_wait_ns(ub_cond *c, ub_mutex *m, int64_t ns)
{
    struct timespec deadline;
    clock_gettime(CLOCK_MONOTONIC, &deadline);
    int64_t nsec = deadline.tv_nsec + ns % 1000000000;
    deadline.tv_sec += (time_t)(ns / 1000000000 + nsec / 1000000000);
    deadline.tv_nsec = (long)(nsec % 1000000000);
    pthread_cond_timedwait(c, m, &deadline);
}
#endif
#endif

/* ---- clock and CPU count ------------------------------------------------------------------ */
static inline double ub_monotonic_seconds(void)
{
#if defined(_WIN32)
    LARGE_INTEGER now, frequency;
    QueryPerformanceCounter(&now);
    QueryPerformanceFrequency(&frequency);
    return (double)now.QuadPart / (double)frequency.QuadPart;
#else
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return ts.tv_sec + 1e-9 * ts.tv_nsec;
#endif
}

static inline int ub_online_cpus(void)
{
#if defined(_WIN32)
    return (int)GetActiveProcessorCount(ALL_PROCESSOR_GROUPS);
#else
    long n = sysconf(_SC_NPROCESSORS_ONLN);
    return n > 0 && n < 1 << 20 ? (int)n : 1;
#endif
}

/* ---- CPU features ------------------------------------------------------------------------- */
/* AVX2 and FMA usable: the CPU has them (cpuid) and the OS saves the YMM registers (xgetbv).
 * Read directly rather than with __builtin_cpu_supports, which links but always answers 0 under
 * zig cc: every zig build would then fall back to the portable kernel, ~15x slower on x86-64. */
static inline int ub_detect_avx2_fma(void)
{
#if defined(UB_X86_64)
    unsigned a, b, c, d;
    if (!__get_cpuid(1, &a, &b, &c, &d))
        return 0;
    const unsigned fma = 1u << 12, osxsave = 1u << 27, avx = 1u << 28;
    if ((c & (fma | osxsave | avx)) != (fma | osxsave | avx))
        return 0;
    unsigned xcr0_lo, xcr0_hi;
    __asm__ volatile("xgetbv" : "=a"(xcr0_lo), "=d"(xcr0_hi) : "c"(0));
    (void)xcr0_hi;
    if ((xcr0_lo & 6u) != 6u) /* XMM and YMM state enabled by the OS */
        return 0;
    if (__get_cpuid_max(0, NULL) < 7)
        return 0;
    __cpuid_count(7, 0, a, b, c, d);
    return (b >> 5) & 1u; /* AVX2 */
#else
    return 0;
#endif
}

/* The AVX-512 kernel usable: the CPU has AVX-512 F, CD, BW, DQ and VL (kernel_avx512.c is compiled
 * for them) and the OS saves the opmask and ZMM registers (XCR0 bits 5-7 beside XMM and YMM). */
static inline int ub_detect_avx512(void)
{
#if defined(UB_X86_64)
    if (!ub_detect_avx2_fma())
        return 0;
    unsigned a, b, c, d, xcr0_lo, xcr0_hi;
    __asm__ volatile("xgetbv" : "=a"(xcr0_lo), "=d"(xcr0_hi) : "c"(0));
    (void)xcr0_hi;
    if ((xcr0_lo & 0xe6u) != 0xe6u)
        return 0;
    __cpuid_count(7, 0, a, b, c, d);
    const unsigned f = 1u << 16, dq = 1u << 17, cd = 1u << 28, bw = 1u << 30, vl = 1u << 31;
    return (b & (f | dq | cd | bw | vl)) == (f | dq | cd | bw | vl);
#else
    return 0;
#endif
}

/* ---- floating-point mode of the kernels --------------------------------------------------- */
/* Same mode for every kernel call, whatever the caller's: round to nearest, subnormals flushed
 * to zero (inputs and results), exceptions masked. Part of what makes pixels independent of the
 * thread, and of the CPU architecture, that computes them. */
static inline uint64_t ub_fp_mode_enter(void)
{
#if defined(UB_X86_64)
    unsigned previous = _mm_getcsr();
    _mm_setcsr(0x1f80 /* all exceptions masked, nearest */ | 0x8000 /* FTZ */ | 0x0040 /* DAZ */);
    return previous;
#elif defined(UB_ARM64)
    uint64_t previous;
    __asm__ volatile("mrs %0, fpcr" : "=r"(previous));
    const uint64_t flush_to_zero = 1ull << 24, rounding = 3ull << 22, traps = 0x9f00ull; /* IDE,IXE..IOE */
    uint64_t mode = (previous & ~(rounding | traps)) | flush_to_zero;
    __asm__ volatile("msr fpcr, %0" : : "r"(mode));
    return previous;
#else
    return 0;
#endif
}

static inline void ub_fp_mode_leave(uint64_t previous)
{
#if defined(UB_X86_64)
    _mm_setcsr((unsigned)previous);
#elif defined(UB_ARM64)
    __asm__ volatile("msr fpcr, %0" : : "r"(previous));
#else
    (void)previous;
#endif
}
#endif
