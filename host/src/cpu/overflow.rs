//! Stack overflows in device programs on the CPU backend: a typed error, not
//! the end of the process.
//!
//! A device program is ordinary Rust on the CPU backend, so it can recurse
//! without end (SPIR-V forbids recursion, so this only happens here) and run off
//! the end of its stack. Rust's own handler then prints a line and aborts the
//! whole process. raykit instead runs every invocation on a stack it owns: the
//! tiles of a launch each in a coroutine ([corosensei](https://crates.io/crates/corosensei)),
//! as the lanes of packet tracing already are, on `mmap`ed stacks of
//! [`THREAD_STACK`] bytes with a guard page below. A `SIGSEGV`/`SIGBUS`
//! handler (installed once, on an alternate signal stack, chaining to the
//! handler it replaced for every other fault) recognises a fault in the guard
//! page of the coroutine running on the faulting thread, and makes that
//! coroutine return at once with corosensei's trap handler. The launch then
//! ends with [`LaunchError::StackOverflow`](crate::LaunchError::StackOverflow)
//! naming the innermost program that was running and its launch index, and
//! the context goes on working.
//!
//! Why guard pages and not a depth budget or a stack-pointer check in the code
//! the macros generate: the recursion that overflows is usually in the user's
//! own functions, which no macro sees, and a check at program entry alone
//! would miss it; the guard page catches every overflow at no cost to
//! programs that do not overflow (one coroutine switch per tile or packet
//! walk, and two thread-local writes per program call to know which program
//! runs).
//!
//! What it costs the abandoned invocation: its frames are discarded without
//! being dropped, so whatever they owned (heap allocations of the program,
//! reference counts) is leaked, once per overflowing launch. Only the
//! launch's own per-tile state is touched by those frames; it is dropped
//! after the launch. The stack that overflowed is unmapped rather than reused,
//! so nothing can still point into it unnoticed; a program that lends its stack
//! to other threads (scoped threads) must not overflow while they run.
//!
//! What it cannot undo: a lock the abandoned frames held stays held, because
//! their guards are never dropped. An overflow in the program's own code (the
//! usual case: recursion in its functions) holds none. An overflow inside code
//! that holds a lock of the process, such as `println!` (stdout's lock), an
//! allocation (the allocator's arena lock, taken in C, which no unwinding could
//! release) or a `Mutex` of the program's own, leaves that lock taken: the
//! launch still ends with the error, but the next user of the lock on another
//! thread waits for ever. Keep deep recursion free of printing, allocation and
//! locks, or bound its depth (an explicit stack or a depth argument), as a GPU
//! program must anyway. On
//! targets other than Linux on x86-64 and AArch64 no handler is installed and an
//! overflow still aborts the process.

use std::cell::Cell;

use corosensei::stack::DefaultStack;
use corosensei::trap::CoroutineTrapHandler;
use corosensei::{Coroutine, CoroutineResult};
use glam::UVec3;
use raykit_device::cpu::CpuProgram;

use super::THREAD_STACK;
use crate::error::DeviceError;
use crate::error::{Error, Result};

/// Where an overflow happened: the innermost program running and its launch index.
#[derive(Copy, Clone, Debug, PartialEq, Eq)]
pub(crate) struct Overflow {
    pub(crate) program: &'static str,
    pub(crate) launch_index: [u32; 3],
}

/// The guard of a coroutine: its trap handler and the lowest address of its
/// stack mapping (the guard page starts there). Made once per coroutine; the
/// thread notes where it is while the coroutine runs.
#[derive(Copy, Clone)]
pub(crate) struct Guard {
    handler: CoroutineTrapHandler<()>,
    guard_page: usize,
}

impl Guard {
    /// The guard of `coroutine`, whose stack's guard page starts at
    /// `guard_page` ([`guard_page_of`] its stack before the coroutine took it).
    pub(crate) fn of<Y, S: corosensei::stack::Stack>(coroutine: &Coroutine<(), Y, (), S>, guard_page: usize) -> Guard {
        Guard { handler: coroutine.trap_handler(), guard_page }
    }
}

thread_local! {
    /// The guard of the coroutine running on this thread, while one runs
    /// (null otherwise): one word to swap on every resumption.
    static GUARD: Cell<*const Guard> = const { Cell::new(std::ptr::null()) };
    /// The program running on this thread and its launch index.
    static RUNNING: Cell<Running> = const { Cell::new(Running::NONE) };
    /// The overflow the signal handler caught, for the code that resumed the coroutine.
    static CAUGHT: Cell<Option<Overflow>> = const { Cell::new(None) };
    /// Stacks of finished tiles, for the next tile on this thread.
    static STACKS: std::cell::RefCell<Vec<DefaultStack>> = const { std::cell::RefCell::new(Vec::new()) };
}

/// What [`enter`] notes: the program running and where the launch index of
/// its invocation is (two words: notes are made on every program call).
#[derive(Copy, Clone)]
pub(crate) struct Running {
    program: Option<&'static CpuProgram>,
    launch_index: *const UVec3,
}

impl Running {
    /// No program runs.
    pub(crate) const NONE: Running = Running { program: None, launch_index: std::ptr::null() };

    /// Where the overflow happened, read by the signal handler: the launch
    /// index is that of an invocation still running (its frames are
    /// abandoned, not unmapped, until the handler has returned).
    #[cfg_attr(not(all(target_os = "linux", any(target_arch = "x86_64", target_arch = "aarch64"))), allow(dead_code))]
    fn overflow(self) -> Overflow {
        match self.program {
            // SAFETY: `enter`'s caller keeps the launch index alive and in
            // place while the program runs (it is its invocation's).
            Some(program) => Overflow { program: program.name, launch_index: unsafe { *self.launch_index }.to_array() },
            None => Overflow { program: "(unknown)", launch_index: [0; 3] },
        }
    }
}

/// Notes that `program` starts running for the invocation whose launch index
/// is at `launch_index`, which stays there until the program returns; returns
/// what ran before, for [`leave`].
#[inline]
pub(crate) fn enter(program: &'static CpuProgram, launch_index: &UVec3) -> Running {
    RUNNING.replace(Running { program: Some(program), launch_index })
}

/// Notes that the program [`enter`] noted has returned (`previous`: what it
/// returned), or that none runs ([`Running::NONE`]).
#[inline]
pub(crate) fn leave(previous: Running) {
    RUNNING.set(previous);
}

/// Readies this thread to catch overflows in guarded coroutines: once per
/// thread before [`resume_guarded`] (which runs often: lanes resume on every
/// packet trace and candidate, so it does not do this itself).
#[inline]
pub(crate) fn ready_thread() {
    handler::install();
}

/// Resumes `coroutine`, whose guard is `guard` ([`Guard::of`]), with its stack
/// overflow guarded; an overflow makes it return (it is then done) and is
/// returned. The thread must be ready ([`ready_thread`]). Inlined: lanes resume
/// on every packet trace.
#[inline]
pub(crate) fn resume_guarded<Y, S: corosensei::stack::Stack>(
    coroutine: &mut Coroutine<(), Y, (), S>,
    guard: &Guard,
) -> (CoroutineResult<Y, ()>, Option<Overflow>) {
    let previous = GUARD.replace(guard);
    let result = coroutine.resume(());
    GUARD.set(previous);
    // An overflow makes the coroutine return: one that suspended did not.
    let overflow = match result {
        CoroutineResult::Return(()) => CAUGHT.take(),
        CoroutineResult::Yield(_) => None,
    };
    (result, overflow)
}

/// The lowest address of `stack`'s mapping, where its guard page is.
pub(crate) fn guard_page_of(stack: &DefaultStack) -> usize {
    use corosensei::stack::Stack;
    stack.limit().get()
}

/// Runs `f` on a stack of [`THREAD_STACK`] bytes whose overflow is caught:
/// `Ok(Some(overflow))` when it overflowed (`f` was abandoned there).
pub(crate) fn run_guarded<F: FnOnce()>(f: F) -> Result<Option<Overflow>> {
    let stack = match STACKS.with_borrow_mut(Vec::pop) {
        Some(stack) => stack,
        None => DefaultStack::new(THREAD_STACK)
            .map_err(|e| Error::Device(DeviceError::CpuThreads { reason: e.to_string() }))?,
    };
    let guard_page = guard_page_of(&stack);
    // SAFETY: the coroutine borrows `f`'s captures, which outlive it: it is
    // driven to completion below (it never suspends), or made to return by the
    // trap handler, before this function returns.
    let mut coroutine: Coroutine<(), (), (), DefaultStack> =
        unsafe { Coroutine::with_stack_unchecked(stack, move |_: &corosensei::Yielder<(), ()>, ()| f()) };
    let guard = Guard::of(&coroutine, guard_page);
    ready_thread();
    let (_, overflow) = resume_guarded(&mut coroutine, &guard);
    // A stack that overflowed is given back (its pages are all touched).
    if coroutine.done() && overflow.is_none() {
        STACKS.with_borrow_mut(|stacks| stacks.push(coroutine.into_stack()));
    }
    Ok(overflow)
}

#[cfg(all(target_os = "linux", any(target_arch = "x86_64", target_arch = "aarch64")))]
mod handler {
    //! The signal handler and its installation.

    use std::sync::OnceLock;

    use corosensei::trap::TrapHandlerRegs;

    use super::{CAUGHT, GUARD, RUNNING};

    /// The handlers raykit replaced (`SIGSEGV`, `SIGBUS`), for the faults that
    /// are not its own.
    static PREVIOUS: OnceLock<[libc::sigaction; 2]> = OnceLock::new();

    /// Bytes of each thread's alternate signal stack, where the handler runs
    /// (the faulting stack has no room left).
    const ALT_STACK: usize = 64 << 10;

    thread_local! {
        /// Whether this thread has an alternate signal stack.
        static ALT_STACK_READY: std::cell::Cell<bool> = const { std::cell::Cell::new(false) };
    }

    type Handler = extern "C" fn(libc::c_int, *mut libc::siginfo_t, *mut libc::c_void);

    /// Installs the handler once per process, and an alternate signal stack
    /// once per thread where it has none.
    pub(super) fn install() {
        PREVIOUS.get_or_init(|| {
            // SAFETY: an all-zero `sigaction` is a valid value (no handler, no flags).
            let mut action: libc::sigaction = unsafe { std::mem::zeroed() };
            action.sa_sigaction = on_fault as Handler as libc::sighandler_t;
            action.sa_flags = libc::SA_SIGINFO | libc::SA_ONSTACK;
            // SAFETY: the mask is a valid `sigset_t` to empty.
            unsafe { libc::sigemptyset(&mut action.sa_mask) };
            // SAFETY: as above; the calls below overwrite them.
            let mut previous: [libc::sigaction; 2] = unsafe { std::mem::zeroed() };
            for (signal, old) in [libc::SIGSEGV, libc::SIGBUS].into_iter().zip(previous.iter_mut()) {
                // SAFETY: valid pointers to a filled action and to where the old one goes;
                // the handler only touches thread-local cells and the trap state.
                unsafe { libc::sigaction(signal, &action, old) };
            }
            previous
        });
        if ALT_STACK_READY.get() {
            return;
        }
        // SAFETY: an all-zero `stack_t` is a valid value to read into.
        let mut current: libc::stack_t = unsafe { std::mem::zeroed() };
        // SAFETY: a null new stack only reads the current one into `current`.
        unsafe { libc::sigaltstack(std::ptr::null(), &mut current) };
        if current.ss_flags & libc::SS_DISABLE != 0 {
            // Leaked: the thread may take a signal until it ends (Rust's own
            // alternate stacks live as long as their thread too).
            let memory: &'static mut [u8] = Box::leak(vec![0u8; ALT_STACK].into_boxed_slice());
            let stack = libc::stack_t { ss_sp: memory.as_mut_ptr().cast(), ss_flags: 0, ss_size: ALT_STACK };
            // SAFETY: `memory` stays valid for the rest of the process.
            unsafe { libc::sigaltstack(&stack, std::ptr::null_mut()) };
        }
        ALT_STACK_READY.set(true);
    }

    /// The page size.
    fn page_size() -> usize {
        // SAFETY: sysconf has no preconditions.
        usize::try_from(unsafe { libc::sysconf(libc::_SC_PAGESIZE) }).unwrap_or(4096)
    }

    /// The stack pointer of the interrupted context.
    #[cfg(target_arch = "x86_64")]
    fn stack_pointer(context: &libc::ucontext_t) -> usize {
        context.uc_mcontext.gregs[libc::REG_RSP as usize] as usize
    }

    /// The stack pointer of the interrupted context.
    #[cfg(target_arch = "aarch64")]
    fn stack_pointer(context: &libc::ucontext_t) -> usize {
        context.uc_mcontext.sp as usize
    }

    /// Points the interrupted context at the trap return corosensei prepared.
    #[cfg(target_arch = "x86_64")]
    fn redirect(context: &mut libc::ucontext_t, regs: TrapHandlerRegs) {
        let TrapHandlerRegs { rip, rsp, rbp, rdi, rsi } = regs;
        let gregs = &mut context.uc_mcontext.gregs;
        gregs[libc::REG_RIP as usize] = rip as i64;
        gregs[libc::REG_RSP as usize] = rsp as i64;
        gregs[libc::REG_RBP as usize] = rbp as i64;
        gregs[libc::REG_RDI as usize] = rdi as i64;
        gregs[libc::REG_RSI as usize] = rsi as i64;
    }

    /// Points the interrupted context at the trap return corosensei prepared.
    #[cfg(target_arch = "aarch64")]
    fn redirect(context: &mut libc::ucontext_t, regs: TrapHandlerRegs) {
        let TrapHandlerRegs { pc, sp, x0, x1, x29, lr } = regs;
        let mcontext = &mut context.uc_mcontext;
        mcontext.pc = pc;
        mcontext.sp = sp;
        mcontext.regs[0] = x0;
        mcontext.regs[1] = x1;
        mcontext.regs[29] = x29;
        mcontext.regs[30] = lr;
    }

    /// The handler: a fault in the guard page of the coroutine running on this
    /// thread ends the coroutine; any other goes to the handler replaced.
    extern "C" fn on_fault(signal: libc::c_int, info: *mut libc::siginfo_t, context: *mut libc::c_void) {
        // SAFETY: the kernel passes a valid `siginfo_t` and `ucontext_t`.
        let (address, context) = unsafe { ((*info).si_addr() as usize, &mut *context.cast::<libc::ucontext_t>()) };
        let guard = GUARD.get();
        // SAFETY: a non-null guard is that of the coroutine running on this
        // thread, which `resume_guarded`'s caller keeps alive while it runs.
        if let Some(guard) = unsafe { guard.as_ref() } {
            let in_guard = address >= guard.guard_page && address < guard.guard_page + page_size();
            if in_guard && guard.handler.stack_ptr_in_bounds(stack_pointer(context)) {
                GUARD.set(std::ptr::null());
                CAUGHT.set(Some(RUNNING.get().overflow()));
                // SAFETY: the stack pointer is inside the coroutine, as
                // `setup_trap_handler` requires, and the registers it names are
                // written back at once. The coroutine wrote outside itself only to
                // the launch's per-tile state, which is dropped after the launch.
                let regs = unsafe { guard.handler.setup_trap_handler(|| ()) };
                redirect(context, regs);
                return;
            }
        }
        chain(signal, info, context);
    }

    /// Hands the fault to the handler raykit replaced (Rust's, which reports
    /// overflows of thread stacks, or the default action).
    fn chain(signal: libc::c_int, info: *mut libc::siginfo_t, context: &mut libc::ucontext_t) {
        let Some(previous) = PREVIOUS.get() else { return };
        let previous = if signal == libc::SIGBUS { &previous[1] } else { &previous[0] };
        let handler = previous.sa_sigaction;
        if handler == libc::SIG_DFL || handler == libc::SIG_IGN {
            // SAFETY: restores the old action; returning re-runs the faulting
            // instruction, which then takes it.
            unsafe { libc::sigaction(signal, previous, std::ptr::null_mut()) };
        } else if previous.sa_flags & libc::SA_SIGINFO != 0 {
            // SAFETY: the previous handler was installed as a three-argument one.
            let f: Handler = unsafe { std::mem::transmute::<libc::sighandler_t, Handler>(handler) };
            f(signal, info, (context as *mut libc::ucontext_t).cast());
        } else {
            // SAFETY: the previous handler was installed as a one-argument one.
            let f = unsafe { std::mem::transmute::<libc::sighandler_t, extern "C" fn(libc::c_int)>(handler) };
            f(signal);
        }
    }
}

#[cfg(not(all(target_os = "linux", any(target_arch = "x86_64", target_arch = "aarch64"))))]
mod handler {
    //! No handler on this target: an overflow aborts the process.

    /// Nothing to install.
    pub(super) fn install() {}
}
