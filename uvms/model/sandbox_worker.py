"""The child process of :mod:`uvms.model.sandbox`: confine this process, then expand one xacro file.

Run as ``python -I -B -c <this file's text>``. The request comes as one JSON document on stdin: ``{"path",
"mappings", "packages", "memory_bytes", "cpu_seconds", "audit_hook", "parent_pid", "landlock", "read_roots"}``;
the answer is one JSON document on stdout: ``{"xml": ...}`` or ``{"kind": "parse"|"xacro"|"unreadable"|
"package"|"unconfined", "message": ...}`` ("package": ``$(find)`` of a package not in ``packages``, the message
its name).

The order matters: read the request, die with the parent (PR_SET_PDEATHSIG), set the resource limits,
import xacro (trusted code), restrict reading to the named folders (Landlock), drop the capabilities,
install the seccomp filter (from then on the kernel refuses what the lists below name, whatever the Python
code does), install the audit hook (a second layer with clearer messages), and only then read the
untrusted file.

:func:`packages_for_find` (xacro's ``$(find)`` through uvms's package index) is also imported by
:mod:`uvms.model.loader` for trusted files: importing this module defines names and runs nothing (``LIBC`` is
a handle on the C library the process has already loaded), on any platform.
"""

import contextlib
import ctypes
import errno
import json
import os
import signal
import stat
import sys
from collections.abc import Iterable, Iterator, Mapping

#: Syscalls refused with EPERM: processes, signals to others, sockets and IPC, every file-system change,
#: raising limits, privileges, namespaces, tracing, kernel state.
DENIED = (
    # new processes and programs
    "fork", "vfork", "clone", "execve", "execveat",
    # signals and handles to other processes
    "kill", "tkill", "tgkill", "rt_sigqueueinfo", "rt_tgsigqueueinfo", "pidfd_open", "pidfd_send_signal",
    "pidfd_getfd", "process_mrelease", "ptrace", "process_vm_readv", "process_vm_writev", "kcmp",
    "setsid", "setpgid",
    # network and inter-process communication
    "socket", "socketpair", "connect", "bind", "listen", "accept", "accept4", "sendto", "sendmsg", "sendmmsg",
    "shmget", "shmat", "shmctl", "msgget", "msgsnd", "msgctl", "semget", "semop", "semtimedop", "semctl",
    "mq_open", "mq_unlink", "mq_timedsend", "mq_notify", "mq_getsetattr",
    # file-system changes (opening for writing is filtered on its flags below)
    "creat", "rename", "renameat", "renameat2", "unlink", "unlinkat", "mkdir", "mkdirat", "rmdir",
    "link", "linkat", "symlink", "symlinkat", "chmod", "fchmod", "fchmodat", "fchmodat2", "chown", "fchown",
    "lchown", "fchownat", "truncate", "ftruncate", "fallocate", "utime", "utimes", "utimensat", "futimesat",
    "mknod", "mknodat", "setxattr", "lsetxattr", "fsetxattr", "removexattr", "lremovexattr", "fremovexattr",
    "flock", "open_by_handle_at", "name_to_handle_at", "fanotify_init", "fanotify_mark",
    "mount", "umount2", "pivot_root", "chroot", "swapon", "swapoff", "fsopen", "fsconfig", "fsmount",
    "fspick", "move_mount", "open_tree", "mount_setattr", "quotactl", "acct",
    # io_uring would run file operations outside this filter
    "io_uring_setup", "io_uring_enter", "io_uring_register",
    # limits, identity, namespaces and kernel state
    "setrlimit", "setuid", "setgid", "setreuid", "setregid", "setresuid", "setresgid", "setfsuid", "setfsgid",
    "setgroups", "capset", "unshare", "setns", "personality", "bpf", "perf_event_open", "userfaultfd",
    "keyctl", "add_key", "request_key", "init_module", "finit_module", "delete_module", "kexec_load",
    "kexec_file_load", "reboot", "settimeofday", "clock_settime", "clock_adjtime", "adjtimex", "sethostname",
    "setdomainname", "syslog", "iopl", "ioperm", "vhangup",
)

#: Syscalls that act on a process named by an argument: refused unless that argument names the caller
#: ({argument index: the value that means "this process"}), so the child cannot renice, pin, reschedule,
#: migrate or inspect another process. Full 64-bit compares: stray high bits are refused too.
SELF_ONLY = {
    "setpriority": {0: 0, 1: 0},  # which == PRIO_PROCESS, who == 0
    "ioprio_set": {0: 1, 1: 0},  # which == IOPRIO_WHO_PROCESS, who == 0
    "sched_setaffinity": {0: 0}, "sched_setscheduler": {0: 0}, "sched_setparam": {0: 0},
    "sched_setattr": {0: 0}, "migrate_pages": {0: 0}, "move_pages": {0: 0},
    "prlimit64": {0: 0, 2: 0},  # own limits, and only to read them
}

#: fcntl commands refused: an owner for SIGIO (a signal, even SIGKILL, sent to any process when the file is
#: ready), and locks and leases, which would hold other processes up.
FCNTL_DENIED = (
    8, 10, 15,  # F_SETOWN, F_SETSIG, F_SETOWN_EX
    1024, 6, 7, 13, 14, 37, 38,  # F_SETLEASE, F_SETLK, F_SETLKW, F_SETLK64, F_SETLKW64, F_OFD_SETLK, F_OFD_SETLKW
)

#: The only ioctl requests allowed (generic numbering: x86, arm, riscv): read a terminal's state (isatty,
#: window size), bytes waiting, close-on-exec and non-blocking on its own descriptors. Everything else is
#: refused: setting a terminal (TCSETS*, TIOCSWINSZ, TIOCSPGRP, TIOCSTI, TCFLSH, TCXONC, TIOCSCTTY...),
#: SIGIO owners (FIOSETOWN, SIOCSPGRP, FIOASYNC), devices.
ALLOWED_IOCTLS = (0x5401, 0x5413, 0x541B, 0x5421, 0x5450, 0x5451)  # TCGETS, TIOCGWINSZ, FIONREAD, FIONBIO,
# FIONCLEX, FIOCLEX

#: Syscall numbers from clone3 (435, Linux 5.3) upward are refused with ENOSYS (as an older kernel would, so
#: the C library falls back) unless harmless: a filter that allows by default must not let through
#: syscalls newer than its list (setxattrat, file_setattr, ...).
FIRST_NEW_SYSCALL = 435
LAST_SYSCALL = 1023
HARMLESS_NEW_SYSCALLS = {
    436,  # close_range
    439,  # faccessat2
    441,  # epoll_pwait2
    444, 445, 446,  # landlock: can only restrict
    449, 454, 455, 456,  # futex_waitv, futex_wake/wait/requeue
    462,  # mseal
}

O_WRITE_FLAGS = (0o1, 0o2, 0o100, 0o1000, 0o2000)  # O_WRONLY, O_RDWR, O_CREAT, O_TRUNC, O_APPEND

PR_SET_PDEATHSIG, PR_SET_NO_NEW_PRIVS = 1, 38
CAP_DAC_OVERRIDE, CAP_DAC_READ_SEARCH = 1, 2
LANDLOCK_READ_FILE, LANDLOCK_READ_DIR = 1 << 2, 1 << 3

LIBC = ctypes.CDLL(None, use_errno=True) if os.name == "posix" else None  # None: Windows may import this module
if LIBC is not None:
    LIBC.syscall.restype = ctypes.c_long


def checked(result: int) -> int:
    """A libc result, or OSError with errno when it is -1."""
    if result < 0:
        code = ctypes.get_errno()
        raise OSError(code, os.strerror(code))
    return result


def die_with_parent(parent_pid: int) -> None:
    """Be killed when the parent dies; exit now if it already has (the child was re-parented)."""
    checked(LIBC.prctl(PR_SET_PDEATHSIG, signal.SIGKILL, 0, 0, 0))
    if os.getppid() != parent_pid:
        os._exit(1)


def limit_resources(memory_bytes: int, cpu_seconds: int) -> None:
    """Address space, CPU time, no file growth, no core file, no new processes, few descriptors."""
    import resource  # POSIX only: imported here so that any platform may import this module

    resource.setrlimit(resource.RLIMIT_AS, (memory_bytes, memory_bytes))
    resource.setrlimit(resource.RLIMIT_CPU, (cpu_seconds, cpu_seconds))
    resource.setrlimit(resource.RLIMIT_FSIZE, (0, 0))
    resource.setrlimit(resource.RLIMIT_CORE, (0, 0))
    resource.setrlimit(resource.RLIMIT_NPROC, (0, 0))
    resource.setrlimit(resource.RLIMIT_NOFILE, (64, 64))


class RulesetAttr(ctypes.Structure):
    _fields_ = [("handled_access_fs", ctypes.c_uint64), ("handled_access_net", ctypes.c_uint64),
                ("scoped", ctypes.c_uint64)]


class PathBeneathAttr(ctypes.Structure):
    _pack_ = 1
    _fields_ = [("allowed_access", ctypes.c_uint64), ("parent_fd", ctypes.c_int32)]


def python_folders() -> set[str]:
    """The Python installation and this child's import folders (modules are imported lazily)."""
    return {p for p in (sys.prefix, sys.base_prefix, sys.exec_prefix, sys.base_exec_prefix, *sys.path)
            if os.path.isabs(p)}


def restrict_reading(roots: Iterable[str], files: Iterable[str]) -> None:
    """Landlock: from now on this process may only read under ``roots`` and read ``files``; no file-system
    change, no TCP, no signal or abstract socket beyond its own domain, whatever its permissions.

    Raises:
        OSError: Landlock refused (ENOSYS/EOPNOTSUPP: not in this kernel).
    """
    abi = checked(LIBC.syscall(444, None, ctypes.c_size_t(0), ctypes.c_uint32(1)))  # ..._VERSION flag
    rights = (1 << 13) - 1 | (abi >= 2) << 13 | (abi >= 3) << 14 | (abi >= 5) << 15  # REFER, TRUNCATE, IOCTL
    attr = RulesetAttr(rights, 3 if abi >= 4 else 0, 3 if abi >= 6 else 0)  # TCP bind/connect; sockets+signals
    ruleset = checked(LIBC.syscall(444, ctypes.byref(attr), ctypes.c_size_t(ctypes.sizeof(attr)), 0))
    try:
        for path, access in [(p, LANDLOCK_READ_FILE | LANDLOCK_READ_DIR) for p in roots] + [
                (p, LANDLOCK_READ_FILE) for p in files]:
            try:
                fd = os.open(path, os.O_PATH | os.O_CLOEXEC)
            except OSError:
                continue  # a folder that is not there holds nothing to read
            try:
                if not stat.S_ISDIR(os.fstat(fd).st_mode):
                    access = LANDLOCK_READ_FILE  # directory rights on a file are invalid
                rule = PathBeneathAttr(access, fd)
                checked(LIBC.syscall(445, ruleset, 1, ctypes.byref(rule), 0))  # LANDLOCK_RULE_PATH_BENEATH
            finally:
                os.close(fd)
        checked(LIBC.prctl(PR_SET_NO_NEW_PRIVS, 1, 0, 0, 0))
        checked(LIBC.syscall(446, ruleset, 0))
    finally:
        os.close(ruleset)


def drop_capabilities() -> None:
    """Keep only reading others' files (so root reads what the user could): a root child may then not
    read another process's environment or memory, renice or signal others, whatever a filter misses."""
    header = (ctypes.c_uint32 * 2)(0x20080522, 0)  # _LINUX_CAPABILITY_VERSION_3, this process
    data = (ctypes.c_uint32 * 6)()  # effective, permitted, inheritable; low then high 32 capabilities
    checked(LIBC.capget(header, data))
    kept = data[1] & (1 << CAP_DAC_OVERRIDE | 1 << CAP_DAC_READ_SEARCH)  # a capability can only be given up
    data[:] = [kept, kept, 0, 0, 0, 0]
    checked(LIBC.capset(header, data))


def install_seccomp_filter() -> None:
    """Load the kernel filter; it holds for this process for good (no_new_privs is set by libseccomp)."""
    import pyseccomp as seccomp

    refuse = seccomp.ERRNO(errno.EPERM)
    arch = seccomp.system_arch()
    rules = seccomp.SyscallFilter(seccomp.ALLOW)

    def number(name: str) -> int:
        try:
            return seccomp.resolve_syscall(arch, name)
        except Exception:  # not a syscall of this architecture
            return -1

    for name in DENIED:
        if number(name) >= 0:
            rules.add_rule(refuse, number(name))
    for flag in O_WRITE_FLAGS:
        rules.add_rule(refuse, "open", seccomp.Arg(1, seccomp.MASKED_EQ, flag, flag))
        rules.add_rule(refuse, "openat", seccomp.Arg(2, seccomp.MASKED_EQ, flag, flag))
    rules.add_rule(seccomp.ERRNO(errno.ENOSYS), "openat2")  # flags in a struct: cannot be inspected
    for name, own in SELF_ONLY.items():
        for index, value in own.items():
            rules.add_rule(refuse, name, seccomp.Arg(index, seccomp.NE, value))
    for name in ("fcntl", "fcntl64"):
        if number(name) >= 0:  # the kernel reads the command as 32 bits: compare only those
            for command in FCNTL_DENIED:
                rules.add_rule(refuse, number(name), seccomp.Arg(1, seccomp.MASKED_EQ, 0xFFFFFFFF, command))
    # libseccomp cannot compare one argument with several values in one rule: an allow-list is written as
    # "refuse below the lowest, above the highest, and each request between that is not allowed"
    low, high = min(ALLOWED_IOCTLS), max(ALLOWED_IOCTLS)
    rules.add_rule(refuse, "ioctl", seccomp.Arg(1, seccomp.LT, low))
    rules.add_rule(refuse, "ioctl", seccomp.Arg(1, seccomp.GT, high))
    for request in set(range(low, high)) - set(ALLOWED_IOCTLS):
        rules.add_rule(refuse, "ioctl", seccomp.Arg(1, seccomp.EQ, request))
    for syscall in range(FIRST_NEW_SYSCALL, LAST_SYSCALL + 1):
        if syscall not in HARMLESS_NEW_SYSCALLS and syscall != number("openat2"):
            rules.add_rule(seccomp.ERRNO(errno.ENOSYS), syscall)
    rules.load()


def install_audit_hook() -> None:
    """Second layer: refuse the same things at the Python level, with a message naming the event."""
    forbidden = ("os.remove", "os.unlink", "os.rename", "os.replace", "os.mkdir", "os.rmdir", "os.chmod",
                 "os.chown", "os.link", "os.symlink", "os.truncate", "os.utime", "os.system", "os.exec",
                 "os.posix_spawn", "os.spawn", "os.fork", "os.forkpty", "os.kill", "os.putenv", "os.unsetenv",
                 "os.mknod", "os.mkfifo", "os.setxattr", "os.removexattr", "os.startfile", "subprocess.",
                 "shutil.", "socket.", "ctypes.", "pty.", "fcntl.", "signal.", "resource.setrlimit",
                 "resource.prlimit", "sqlite3.", "webbrowser.", "_posixsubprocess.")
    write_flags = 0
    for flag in O_WRITE_FLAGS:
        write_flags |= flag

    def hook(event: str, args: tuple) -> None:
        if event == "open":
            mode, flags = args[1], args[2]
            writes = (isinstance(mode, str) and any(c in mode for c in "wax+")) or (
                isinstance(flags, int) and flags & write_flags)
            if writes:
                raise PermissionError(f"untrusted xacro may not write files (tried {args[0]!r})")
        elif event.startswith(forbidden):
            raise PermissionError(f"untrusted xacro may not do {event}")

    sys.addaudithook(hook)


class PackageNotFound(LookupError):
    """``$(find name)`` of a package that is not in the package index; ``args[0]`` is the name."""


@contextlib.contextmanager
def packages_for_find(packages: Mapping[str, str]) -> Iterator[None]:
    """While inside, xacro's ``$(find pkg)`` (and ``find('pkg')`` in ``$(eval ...)``) is ``packages[pkg]``.

    The one place that sets xacro's find resolution (xacro 2 asks ament_index, which uvms does not need): this
    child and the trusted expansion of :mod:`uvms.model.loader` alike. A name not in ``packages`` raises
    :class:`PackageNotFound`. xacro's own resolution is restored on exit.

    Args:
        packages: {package name: its folder} (:func:`uvms.model.packages.package_index`).
    """
    from xacro import substitution_args

    def find(name: object) -> str:
        if not isinstance(name, str) or name not in packages:
            raise PackageNotFound(str(name))
        return str(packages[name])

    saved = substitution_args._eval_find, substitution_args._eval_dict.get("find")
    substitution_args._eval_find = substitution_args._eval_dict["find"] = find
    try:
        yield
    finally:
        substitution_args._eval_find = saved[0]
        if saved[1] is None:
            substitution_args._eval_dict.pop("find", None)
        else:
            substitution_args._eval_dict["find"] = saved[1]


def causes(exc: BaseException | None) -> Iterator[BaseException]:
    """``exc`` and what it wraps (xacro's ``.exc``, ``__cause__``, ``__context__``), each once."""
    seen = set()
    while exc is not None and id(exc) not in seen:
        seen.add(id(exc))
        yield exc
        exc = getattr(exc, "exc", None) or exc.__cause__ or exc.__context__


def unreadable(exc: BaseException | None) -> str | None:
    """The file Landlock kept xacro from reading (EACCES somewhere in the chain of ``exc``), or None."""
    return next((cause.filename or "?" for cause in causes(exc)
                 if isinstance(cause, PermissionError) and cause.errno == errno.EACCES), None)


def missing_package(exc: BaseException | None) -> str | None:
    """The package that ``$(find)`` did not find (a :class:`PackageNotFound` in the chain of ``exc``), or None."""
    return next((str(cause.args[0]) for cause in causes(exc) if isinstance(cause, PackageNotFound)), None)


def answer(document: dict[str, str]) -> None:
    """Hand the one JSON answer to the parent."""
    sys.stdout.write(json.dumps(document))
    sys.stdout.flush()


def main() -> None:
    """Confine this process in the order above, then expand the file and answer."""
    request = json.loads(sys.stdin.read())
    try:
        die_with_parent(request["parent_pid"])
        limit_resources(request["memory_bytes"], request["cpu_seconds"])
        # trusted code, imported before the filters: what it loads (libseccomp, yaml's C part) comes from
        # system folders that Landlock then hides; xacro imports substitution_args and yaml lazily
        from xml.parsers.expat import ExpatError

        import pyseccomp  # noqa: F401
        import xacro
        import xacro.substitution_args  # noqa: F401 - imports yaml

        if request["landlock"]:
            restrict_reading(python_folders() | set(request["read_roots"]), ("/dev/null", "/dev/urandom"))
        drop_capabilities()
        install_seccomp_filter()
    except Exception as exc:  # no libseccomp, an old kernel, ...: refuse rather than run unconfined
        answer({"kind": "unconfined", "message": f"{type(exc).__name__}: {exc}"})
        return
    if request["audit_hook"]:
        install_audit_hook()
    try:
        with packages_for_find(request["packages"]):
            document = xacro.process_file(request["path"], mappings=request["mappings"])
        answer({"xml": document.toprettyxml(indent="  ")})
    except ExpatError as exc:
        answer({"kind": "parse", "message": str(exc)})
    except RecursionError:
        answer({"kind": "xacro", "message": "recursion too deep (does the file include itself?)"})
    except MemoryError:
        answer({"kind": "xacro", "message": f"needs more than {request['memory_bytes'] >> 20} MiB of memory"})
    except BaseException as exc:  # xacro's errors, what the filters and the hook refused, anything else
        text = " ".join(str(exc).split()) if isinstance(exc, xacro.XacroException) else " ".join(
            f"{type(exc).__name__}: {exc}".split())
        if missing_package(exc) is not None:
            answer({"kind": "package", "message": missing_package(exc)})
        else:
            answer({"kind": "unreadable" if unreadable(exc) else "xacro", "message": text})


if __name__ == "__main__":  # run as ``python -c`` by the sandbox; importing it does nothing
    main()
