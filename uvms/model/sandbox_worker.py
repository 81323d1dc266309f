"""The child process of :mod:`uvms.sandbox`: confine this process, then expand one xacro file.

Run as ``python -I -B -c <this file's text>`` (never imported by uvms). The request comes as one JSON
document on stdin: ``{"path", "mappings", "memory_bytes", "cpu_seconds", "audit_hook"}``; the answer is one
JSON document on stdout: ``{"xml": ...}`` or ``{"kind": "parse"|"xacro"|"unconfined", "message": ...}``.

The order matters: read the request, set the resource limits, import xacro (trusted code), install the
seccomp filter (from then on the kernel refuses what the list below names, whatever the Python code does),
install the audit hook (a second layer with clearer messages), and only then read the untrusted file.
"""

import errno
import json
import resource
import sys

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
TERMINAL_INJECTION = (0x5412, 0x541C)  # TIOCSTI, TIOCLINUX


def limit_resources(memory_bytes, cpu_seconds):
    """Address space, CPU time, no file growth, no core file, no new processes, few descriptors."""
    resource.setrlimit(resource.RLIMIT_AS, (memory_bytes, memory_bytes))
    resource.setrlimit(resource.RLIMIT_CPU, (cpu_seconds, cpu_seconds))
    resource.setrlimit(resource.RLIMIT_FSIZE, (0, 0))
    resource.setrlimit(resource.RLIMIT_CORE, (0, 0))
    resource.setrlimit(resource.RLIMIT_NPROC, (0, 0))
    resource.setrlimit(resource.RLIMIT_NOFILE, (64, 64))


def install_seccomp_filter():
    """Load the kernel filter; it holds for this process for good (no_new_privs is set by libseccomp)."""
    import pyseccomp as seccomp

    refuse = seccomp.ERRNO(errno.EPERM)
    arch = seccomp.system_arch()
    rules = seccomp.SyscallFilter(seccomp.ALLOW)
    for name in DENIED:
        try:
            number = seccomp.resolve_syscall(arch, name)
        except Exception:  # not a syscall of this architecture
            continue
        if number >= 0:
            rules.add_rule(refuse, number)
    for flag in O_WRITE_FLAGS:
        rules.add_rule(refuse, "open", seccomp.Arg(1, seccomp.MASKED_EQ, flag, flag))
        rules.add_rule(refuse, "openat", seccomp.Arg(2, seccomp.MASKED_EQ, flag, flag))
    rules.add_rule(seccomp.ERRNO(errno.ENOSYS), "openat2")  # flags in a struct: cannot be inspected
    rules.add_rule(refuse, "prlimit64", seccomp.Arg(2, seccomp.NE, 0))  # reading limits stays allowed
    for request in TERMINAL_INJECTION:
        rules.add_rule(refuse, "ioctl", seccomp.Arg(1, seccomp.EQ, request))
    for number in range(FIRST_NEW_SYSCALL, LAST_SYSCALL + 1):
        if number not in HARMLESS_NEW_SYSCALLS and number != seccomp.resolve_syscall(arch, "openat2"):
            rules.add_rule(seccomp.ERRNO(errno.ENOSYS), number)
    rules.load()


def install_audit_hook():
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

    def hook(event, args):
        if event == "open":
            mode, flags = args[1], args[2]
            writes = (isinstance(mode, str) and any(c in mode for c in "wax+")) or (
                isinstance(flags, int) and flags & write_flags)
            if writes:
                raise PermissionError(f"untrusted xacro may not write files (tried {args[0]!r})")
        elif event.startswith(forbidden):
            raise PermissionError(f"untrusted xacro may not do {event}")

    sys.addaudithook(hook)


def answer(document):
    sys.stdout.write(json.dumps(document))
    sys.stdout.flush()


def main():
    request = json.loads(sys.stdin.read())
    try:
        limit_resources(request["memory_bytes"], request["cpu_seconds"])
        import xacro  # trusted code, imported before the filter
        from xml.parsers.expat import ExpatError

        install_seccomp_filter()
    except Exception as exc:  # no libseccomp, an old kernel, ...: refuse rather than run unconfined
        answer({"kind": "unconfined", "message": f"{type(exc).__name__}: {exc}"})
        return
    if request["audit_hook"]:
        install_audit_hook()
    try:
        document = xacro.process_file(request["path"], mappings=request["mappings"])
        answer({"xml": document.toprettyxml(indent="  ")})
    except ExpatError as exc:
        answer({"kind": "parse", "message": str(exc)})
    except RecursionError:
        answer({"kind": "xacro", "message": "recursion too deep (does the file include itself?)"})
    except MemoryError:
        answer({"kind": "xacro", "message": f"needs more than {request['memory_bytes'] >> 20} MiB of memory"})
    except xacro.XacroException as exc:
        answer({"kind": "xacro", "message": " ".join(str(exc).split())})
    except BaseException as exc:  # what the filter and the hook refused, and anything else
        answer({"kind": "xacro", "message": " ".join(f"{type(exc).__name__}: {exc}".split())})


main()
