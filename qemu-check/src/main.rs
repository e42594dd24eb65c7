//! The QEMU check program for the Cortex-M4F (`qemu-system-arm -machine mps2-an386`).
//!
//! It reads a mode word at [`qemu_check::MODE_ADDR`] (0 unless QEMU's generic loader sets it) and
//! * mode 0: runs check variant `arg` ([`qemu_check::run_check`]: the test scene through a
//!   configuration, or an input kind in the firmware's blocks) and prints every estimate's bits (and,
//!   with the multi-talker tracks on, the decided tracks' bits) over semihosting, then `END <count>`;
//! * modes 1–7: runs the pipeline, the scene generator or one stage `arg` times, silently, for
//!   instruction counting (`scripts/cost.sh`);
//! * mode 8: runs hops of an input kind in the firmware's blocks, default or multi-talker configuration
//!   (see [`qemu_check::Mode::Hops`]), entering
//!   the mark functions that `scripts/cost.sh` follows for per-hop counts;
//! * mode 9: runs the pipeline with the multi-talker tracks on `arg` times, silently (the cost of
//!   that configuration, `scripts/cost.sh`).
//!
//! It exits QEMU with status 0, or 1 after a panic or a HardFault.
#![cfg_attr(target_os = "none", no_std, no_main)]

#[cfg(target_os = "none")]
mod target {
    use core::mem::MaybeUninit;
    use core::sync::atomic::{compiler_fence, Ordering::SeqCst};
    use cortex_m::asm::nop;
    use cortex_m_rt::{entry, exception, ExceptionFrame};
    use cortex_m_semihosting::{debug, hprintln};
    use qemu_check::{
        inputs::InputKind, multi_talker_config, run_check, run_hops, run_scene, run_scene_with,
        stages::Bench, HopMarks, Mode, FIRMWARE_BLOCK, FIRMWARE_RATE_HZ, MODE_ADDR,
    };

    // The mark functions: `scripts/cost.sh` finds them by name. Their `nop`s (an `asm!` each, which
    // the optimiser keeps) make the bodies different, so that none is removed or merged with another;
    // their fences keep the compiler from moving memory accesses (input generation) across them.

    /// Entered before input generation.
    #[inline(never)]
    fn cost_mark_pause() {
        compiler_fence(SeqCst);
        nop();
    }

    /// Entered after input generation.
    #[inline(never)]
    fn cost_mark_resume() {
        compiler_fence(SeqCst);
        nop();
        nop();
    }

    /// Entered with every estimate.
    #[inline(never)]
    fn cost_mark_hop() {
        compiler_fence(SeqCst);
        nop();
        nop();
        nop();
    }

    struct Marks;

    impl HopMarks for Marks {
        fn pause(&mut self) {
            cost_mark_pause();
        }
        fn resume(&mut self) {
            cost_mark_resume();
        }
        fn hop(&mut self, _: &cma_core::Estimate) {
            cost_mark_hop();
        }
    }

    #[entry]
    fn main() -> ! {
        // Note(unsafe): MODE_ADDR is RAM of the mps2-an386 outside every linked section (see memory.x);
        // QEMU zeroes it or its loader writes it before the program starts.
        #[allow(unsafe_code)]
        let (word, arg) = unsafe {
            (
                core::ptr::read_volatile(MODE_ADDR as *const u32),
                core::ptr::read_volatile((MODE_ADDR + 4) as *const u32) as usize,
            )
        };
        match Mode::from_word(word) {
            Some(Mode::Check) => {
                let mut n = 0u32;
                let known = run_check(arg, |line| {
                    hprintln!("{}", line);
                    n += 1;
                });
                if !known {
                    hprintln!("unknown check variant {}", arg);
                    exit(debug::EXIT_FAILURE)
                }
                hprintln!("END {}", n);
            }
            Some(Mode::Pipeline) => run_scene(arg, true, |e| {
                core::hint::black_box(e);
            }),
            Some(Mode::Generate) => run_scene(arg, false, |_| {}),
            Some(Mode::PipelineMultiTalker) => {
                run_scene_with(multi_talker_config(), FIRMWARE_RATE_HZ, arg, true, |e| {
                    core::hint::black_box(e);
                })
            }
            Some(Mode::Hops) => {
                let Some(kind) = InputKind::from_index(arg as u32 & 0xff) else {
                    hprintln!("unknown input kind {}", arg & 0xff);
                    exit(debug::EXIT_FAILURE)
                };
                let block = match (arg >> 20) & 0x7ff {
                    0 => FIRMWARE_BLOCK,
                    b => b,
                };
                let config = if arg >> 31 == 1 {
                    multi_talker_config()
                } else {
                    cma_core::LocatorConfig::default()
                };
                run_hops(config, kind, (arg >> 8) & 0xfff, block, &mut Marks);
            }
            Some(Mode::Stage(stage)) => {
                let mut slot = MaybeUninit::uninit();
                let bench = Bench::new(&mut slot);
                for _ in 0..arg {
                    bench.run(stage);
                }
                core::hint::black_box(bench.num_peaks());
            }
            None => {
                hprintln!("unknown mode {}", word);
                exit(debug::EXIT_FAILURE)
            }
        }
        exit(debug::EXIT_SUCCESS)
    }

    /// Ends the QEMU run with `status` (semihosting); waits for the end if the host has not ended it.
    fn exit(status: debug::ExitStatus) -> ! {
        debug::exit(status);
        loop {
            cortex_m::asm::wfi();
        }
    }

    #[panic_handler]
    fn panic(info: &core::panic::PanicInfo) -> ! {
        hprintln!("PANIC {}", info);
        exit(debug::EXIT_FAILURE)
    }

    // Note(unsafe): cortex-m-rt requires the HardFault handler to be an `unsafe fn`.
    #[allow(unsafe_code)]
    #[exception]
    unsafe fn HardFault(frame: &ExceptionFrame) -> ! {
        hprintln!("HARDFAULT at pc {:#010x}", frame.pc());
        exit(debug::EXIT_FAILURE)
    }
}

#[cfg(not(target_os = "none"))]
fn main() {
    eprintln!(
        "qemu-check: build with --target thumbv7em-none-eabihf and run under qemu-system-arm"
    );
}
