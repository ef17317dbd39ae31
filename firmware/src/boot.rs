//! Boot and end of every firmware binary: stack painting, the guarded task
//! stack, the watchdog, the embassy executor, the boot line, the fault
//! self-tests, and the final stack report + exit.
//!
//! A binary (src/bin/*.rs) is one [`firmware_main!`] line: the entry point,
//! the executor and one supervisor task that prints the boot line, runs its
//! mode and ends in [`finish`]:
//!
//! ```ignore
//! gpecnet_firmware::firmware_main!(Supervision::On, |_spawner| golden_run::run());
//! ```

use embassy_executor::{Executor, Spawner};

use crate::{fatal, guard, stack, watchdog};

/// Whether the QEMU watchdog supervisor runs (see [`watchdog::start`]).
#[derive(Clone, Copy, PartialEq, Eq)]
pub enum Supervision {
    /// SysTick supervisor under QEMU, the chip's watchdog on a board.
    On,
    /// Only the board's watchdog: the profile build, so that no interrupt
    /// lands in the measured instruction window.
    BoardOnly,
}

/// Paints the stack and continues in `tasks` on the guarded task stack. Call
/// first thing in the entry point.
pub fn start(tasks: extern "C" fn() -> !) -> ! {
    // Before anything else uses the stack below us.
    stack::paint();
    // From here on the tasks run on the guarded process stack.
    guard::run_guarded(tasks)
}

/// Starts the watchdog and runs the executor with `spawn` spawning the first task.
pub fn executor(supervision: Supervision, spawn: impl FnOnce(Spawner)) -> ! {
    watchdog::start(supervision == Supervision::On);
    let executor = cortex_m::singleton!(: Executor = Executor::new());
    let Some(executor) = executor else {
        defmt::error!("boot: executor started twice");
        fatal::exit(1)
    };
    executor.run(spawn)
}

/// The boot line, then the injected faults of the `force-*` features.
pub fn banner() {
    #[cfg(not(model_pack))]
    defmt::println!(
        "boot: gpecnet firmware {=str} on {=str} (embassy executor up), {=usize} model(s) embedded",
        env!("CARGO_PKG_VERSION"),
        env!("GPECNET_CHIP"),
        crate::models::BLOBS.len()
    );
    // An image linked for a model pack: the replay names the pack's models.
    #[cfg(model_pack)]
    defmt::println!(
        "boot: gpecnet firmware {=str} on {=str} (embassy executor up), models from the image's model pack",
        env!("CARGO_PKG_VERSION"),
        env!("GPECNET_CHIP")
    );
    fatal::self_tests();
}

/// Stack report + exit (QEMU) / park (board).
pub fn finish(ok: bool) -> ! {
    let used = stack::high_water();
    defmt::println!(
        "stack: high-water {=u32} B of {=u32} B",
        used as u32,
        stack::size() as u32
    );
    if ok {
        defmt::println!("result: PASS");
        fatal::exit(0)
    } else {
        defmt::error!("result: FAIL");
        fatal::exit(1)
    }
}

/// A whole firmware binary: the entry point ([`start`] on the guarded
/// stack), [`executor`] with `$supervision`, and the supervisor task it
/// spawns, which prints the [`banner`], evaluates `$mode` (a `bool`, `true`
/// when the mode passed; it may `.await` and use the executor's spawner,
/// bound to `$spawner`) and ends in [`finish`].
#[macro_export]
macro_rules! firmware_main {
    ($supervision:expr, |$spawner:ident| $mode:expr) => {
        #[::cortex_m_rt::entry]
        fn main() -> ! {
            $crate::boot::start(tasks)
        }

        extern "C" fn tasks() -> ! {
            $crate::boot::executor($supervision, |s| s.spawn(supervisor(s).unwrap()))
        }

        #[::embassy_executor::task]
        async fn supervisor($spawner: ::embassy_executor::Spawner) {
            $crate::boot::banner();
            $crate::boot::finish($mode)
        }
    };
}
