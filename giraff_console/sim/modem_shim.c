/*
 * Modem lines for pseudo-terminals: an LD_PRELOAD shim for `giraff-console sim --pty`.
 *
 * A Linux pty has no modem-control lines, so the ioctls that read and set DTR/RTS
 * (TIOCMGET, TIOCMSET, TIOCMBIS, TIOCMBIC) fail on it with ENOTTY ("Inappropriate
 * ioctl for device"). Real Giraff drivers make those calls before anything else, to
 * power the board up (wire-facts: "Opening the port"), and give up when they fail.
 *
 * This library wraps ioctl(). Every call goes to the real ioctl first. Only when a
 * modem-line request fails with ENOTTY or EINVAL on the slave side of a pseudo-terminal
 * does it step in: it remembers the lines the program set, per pty, and reports
 * success. TIOCMGET returns what was last set, with CTS, DSR and CD raised, as a
 * powered board on a straight cable would show them, so drivers that wait for them
 * carry on. Anything else, and any failure on a real port, a pipe or a file, is
 * returned unchanged, errno and all.
 *
 * Use: LD_PRELOAD=$(giraff-console sim --modem-shim) ./driver /dev/pts/N
 * Built by giraff_console/sim/modem_shim.py: cc -shared -fPIC -O2 modem_shim.c -ldl
 *
 * Programs that make the system call themselves (static binaries, Go) never reach
 * this wrapper; neither does glibc's own internal use of ioctl (tcsetattr and the
 * like), which is fine: those work on a pty.
 */
#define _GNU_SOURCE
#include <dlfcn.h>
#include <errno.h>
#include <stdarg.h>
#include <stddef.h>
#include <sys/ioctl.h>
#include <sys/stat.h>
#include <sys/sysmacros.h>
#include <sys/types.h>
#include <termios.h>
#include <unistd.h>

/* glibc declares ioctl(int, unsigned long, ...); musl ioctl(int, int, ...). */
#ifdef __GLIBC__
typedef unsigned long request_t;
#else
typedef int request_t;
#endif
typedef int (*ioctl_fn)(int, request_t, ...);

/* UNIX98 pty slaves (/dev/pts/N) have majors 136-143 (Documentation/admin-guide/devices.txt). */
#define PTY_SLAVE_MAJOR_FIRST 136
#define PTY_SLAVE_MAJOR_LAST 143

/* The lines a program may set, and the ones a powered board raises for it to read. */
#define SETTABLE (TIOCM_DTR | TIOCM_RTS)
#define FROM_BOARD (TIOCM_CTS | TIOCM_DSR | TIOCM_CD)
/* Linux raises DTR and RTS when a serial port is opened; a pty starts the same way. */
#define AT_OPEN (TIOCM_DTR | TIOCM_RTS)

/*
 * The lines belong to the port, not to the file descriptor: every fd open on the same
 * pty sees the same lines, as on a real port. One slot per pty, keyed by its device
 * number, lock-free so that the wrapper is safe from any thread or signal handler.
 * A slot holds the lines XOR AT_OPEN, so a fresh (zeroed) slot reads as a just-opened
 * port without a separate initialisation that another thread could race. A program
 * with more ptys than slots still gets success; the extra ptys just forget their lines.
 */
#define SLOTS 64
static dev_t slot_device[SLOTS];
static int slot_lines[SLOTS];
static int spare_lines; /* for ptys beyond SLOTS */

static ioctl_fn real_ioctl(const char *name) {
    return (ioctl_fn)dlsym(RTLD_NEXT, name);
}

static int is_modem_request(request_t request) {
    return request == TIOCMGET || request == TIOCMSET || request == TIOCMBIS ||
           request == TIOCMBIC;
}

static int is_pty_slave(int fd, dev_t *device) {
    struct stat st;
    if (fstat(fd, &st) != 0 || !S_ISCHR(st.st_mode))
        return 0;
    unsigned int major_number = major(st.st_rdev);
    *device = st.st_rdev;
    return major_number >= PTY_SLAVE_MAJOR_FIRST && major_number <= PTY_SLAVE_MAJOR_LAST;
}

static int *lines_of(dev_t device) {
    for (int i = 0; i < SLOTS; i++) {
        dev_t held = __atomic_load_n(&slot_device[i], __ATOMIC_ACQUIRE);
        if (held == device)
            return &slot_lines[i];
        if (held == 0) {
            dev_t empty = 0;
            if (__atomic_compare_exchange_n(&slot_device[i], &empty, device, 0,
                                            __ATOMIC_ACQ_REL, __ATOMIC_ACQUIRE))
                return &slot_lines[i];
            if (empty == device) /* another thread took this slot for the same pty */
                return &slot_lines[i];
        }
    }
    return &spare_lines;
}

static int emulate(dev_t device, request_t request, int *arg) {
    if (arg == NULL) {
        errno = EFAULT;
        return -1;
    }
    int *slot = lines_of(device);
    if (request == TIOCMGET) {
        int lines = __atomic_load_n(slot, __ATOMIC_ACQUIRE) ^ AT_OPEN;
        *arg = (lines & SETTABLE) | FROM_BOARD;
        return 0;
    }
    int bits = *arg & SETTABLE;
    int old = __atomic_load_n(slot, __ATOMIC_ACQUIRE);
    int lines;
    do {
        lines = old ^ AT_OPEN;
        if (request == TIOCMSET)
            lines = bits;
        else if (request == TIOCMBIS)
            lines |= bits;
        else
            lines &= ~bits;
    } while (!__atomic_compare_exchange_n(slot, &old, lines ^ AT_OPEN, 0, __ATOMIC_ACQ_REL,
                                          __ATOMIC_ACQUIRE));
    return 0;
}

static int wrapped(ioctl_fn real, int fd, request_t request, void *arg) {
    if (real == NULL) {
        errno = ENOSYS;
        return -1;
    }
    int result = real(fd, request, arg);
    if (result != -1 || !is_modem_request(request) || (errno != ENOTTY && errno != EINVAL))
        return result;
    int failure = errno;
    dev_t device;
    if (is_pty_slave(fd, &device))
        return emulate(device, request, (int *)arg);
    errno = failure;
    return result;
}

/* ioctl's third argument is a pointer or an int; both travel as one machine word. */
int ioctl(int fd, request_t request, ...) {
    static ioctl_fn real;
    ioctl_fn found = __atomic_load_n(&real, __ATOMIC_ACQUIRE);
    if (found == NULL) {
        found = real_ioctl("ioctl");
        __atomic_store_n(&real, found, __ATOMIC_RELEASE);
    }
    va_list args;
    va_start(args, request);
    void *arg = va_arg(args, void *);
    va_end(args);
    return wrapped(found, fd, request, arg);
}

#if defined(__GLIBC__) && defined(__TIMESIZE) && __TIMESIZE != 64
/* 32-bit programs built with 64-bit time_t (_TIME_BITS=64, the default on Debian 13
 * armhf and i386) call this name instead of ioctl. */
int __ioctl_time64(int fd, request_t request, ...) {
    static ioctl_fn real;
    ioctl_fn found = __atomic_load_n(&real, __ATOMIC_ACQUIRE);
    if (found == NULL) {
        found = real_ioctl("__ioctl_time64");
        __atomic_store_n(&real, found, __ATOMIC_RELEASE);
    }
    va_list args;
    va_start(args, request);
    void *arg = va_arg(args, void *);
    va_end(args);
    return wrapped(found, fd, request, arg);
}
#endif
