//! Blocks of invocations run side by side as coroutines (corosensei), so that
//! their traces can be made together: an invocation that traces a ray a packet
//! can take writes it into the block's packet and suspends; once every
//! invocation of the block has suspended or finished, the block traces the
//! packet and resumes them. Everything else an invocation does runs as before,
//! on its own stack; the programs of the boxes a walk finds run on the walk's
//! (see [`super::launch`]).
//!
//! Stacks are as deep as the pool's threads', start [`STAGGER`] bytes apart
//! modulo a page, and are kept per thread for the next block.

use std::cell::RefCell;

use corosensei::stack::{DefaultStack, Stack, StackPointer};
use corosensei::{Coroutine, CoroutineResult, Yielder};

use super::overflow::{Guard, Overflow};
use super::packet::WIDTH;
use super::THREAD_STACK;
use crate::error::DeviceError;
use crate::error::{Error, Result};

/// What an invocation running in a lane suspends through.
pub(crate) type LaneYielder = Yielder<(), ()>;

type Lane = Coroutine<(), (), (), LaneStack>;

/// How far apart the lanes' stacks start, modulo a page: their hot frames then
/// fall on different sets of the first-level cache instead of all on the same
/// ones (every stack's top is page-aligned).
const STAGGER: usize = 4096 / WIDTH;

/// A pool thread's stack, used from `offset` bytes below its top.
struct LaneStack {
    stack: DefaultStack,
    offset: usize,
}

// SAFETY: the base is inside the stack, `offset` (less than a page) below the
// top of a stack of `THREAD_STACK` bytes, and aligned as the top is (`offset`
// is a multiple of the stack alignment); the limit is the stack's own.
unsafe impl Stack for LaneStack {
    fn base(&self) -> StackPointer {
        StackPointer::new(self.stack.base().get() - self.offset).unwrap_or(self.stack.base())
    }

    fn limit(&self) -> StackPointer {
        self.stack.limit()
    }
}

// The staggered tops stay aligned and within a page of the real ones.
const _: () = assert!(STAGGER.is_multiple_of(corosensei::stack::STACK_ALIGNMENT) && STAGGER * WIDTH <= 4096);

thread_local! {
    /// Stacks of finished lanes, for the next block on this thread.
    static STACKS: RefCell<Vec<DefaultStack>> = const { RefCell::new(Vec::new()) };
}

/// Runs `body(lane, yielder)` for each lane of `0..count` (at most
/// [`WIDTH`]), each in a coroutine of its own. Whenever every lane has
/// suspended or returned, and some suspended, `trace` runs and then the
/// suspended lanes are resumed. A lane that overflows its stack ends there
/// (see [`super::overflow`]); the overflows are returned.
pub(crate) fn run_lanes<F, T>(count: usize, body: &F, mut trace: T) -> Result<Vec<Overflow>>
where
    F: Fn(usize, &LaneYielder),
    T: FnMut(),
{
    debug_assert!(count <= WIDTH);
    let mut lanes: Vec<Lane> = Vec::with_capacity(count);
    let mut guards = Vec::with_capacity(count);
    for lane in 0..count {
        let stack = match STACKS.with_borrow_mut(Vec::pop) {
            Some(stack) => stack,
            None => DefaultStack::new(THREAD_STACK)
                .map_err(|e| Error::Device(DeviceError::CpuThreads { reason: e.to_string() }))?,
        };
        let guard_page = super::overflow::guard_page_of(&stack);
        let stack = LaneStack { stack, offset: lane * STAGGER };
        // SAFETY: the coroutine borrows `body`, which outlives this function;
        // every lane is driven to completion below or dropped (unwound) before
        // it returns.
        let coroutine =
            unsafe { Coroutine::with_stack_unchecked(stack, move |yielder: &LaneYielder, ()| body(lane, yielder)) };
        guards.push(Guard::of(&coroutine, guard_page));
        lanes.push(coroutine);
    }
    let mut overflows: Vec<Option<Overflow>> = vec![None; count];
    super::overflow::ready_thread();
    loop {
        let mut suspended = false;
        for (lane, coroutine) in lanes.iter_mut().enumerate().filter(|(_, lane)| !lane.done()) {
            let (result, overflow) = super::overflow::resume_guarded(coroutine, &guards[lane]);
            suspended |= matches!(result, CoroutineResult::Yield(()));
            if overflow.is_some() {
                overflows[lane] = overflow;
            }
        }
        if !suspended {
            break;
        }
        trace();
    }
    // The stack of a lane that overflowed is given back (its pages are all
    // touched), the others kept for the next block.
    let kept = lanes.into_iter().zip(&overflows).filter(|(_, o)| o.is_none()).map(|(lane, _)| lane.into_stack().stack);
    STACKS.with_borrow_mut(|stacks| stacks.extend(kept));
    Ok(overflows.into_iter().flatten().collect())
}
