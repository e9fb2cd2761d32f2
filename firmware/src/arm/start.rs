//! Reset entry, exception vectors and the first steps before any Rust code runs.
//!
//! QEMU's `-kernel <elf>` (machine `xilinx-zynq-a9`) loads the ELF segments at their physical
//! addresses and jumps to `_start` in a privileged mode (SVC), ARM state, MMU and caches off.
//! A first-stage boot loader on real silicon hands over the same way. `_start`:
//!
//! 1. masks interrupts and parks every CPU but CPU 0 (MPIDR.Aff0 != 0) in `wfe`;
//! 2. switches to SVC mode and sets SP to `_stack_top` (top of RAM, see link.x);
//! 3. points VBAR at `_vectors` (and clears SCTLR.V so that VBAR is used);
//! 4. enables the VFP/NEON unit: CPACR cp10/cp11 = full access, then FPEXC.EN
//!    (without this the first floating-point instruction raises an undefined-instruction trap);
//! 5. zeroes `.bss` and copies `.data` from its load address if that differs;
//! 6. calls `fsm_fw_init` (Rust, src/arm/cpu.rs: MMU identity map + caches, cycle counter);
//! 7. calls the application's `fw_main() -> !` (defined by the binary, src/main.rs).
//!
//! Every vector but reset goes to `fsm_fw_exception` (src/arm/mod.rs), which reports the
//! exception on the console and stops (`arm::stop`: a failure code to QEMU or the debugger,
//! a reset of the SoC on a board) instead of hanging. The one exception: a semihosting call
//! that nobody answers returns -1 to its caller (see `_fsm_exc_svc`).
//!
//! U-Boot's `go` and a raw-binary boot start at the image's first byte, the reset vector,
//! which branches to `_start`: the load address is the entry.

core::arch::global_asm!(
    r#"
    .section .vectors, "ax", %progbits
    .arm
    .p2align 5
    .global _vectors
_vectors:
    b   _start
    b   _fsm_exc_und
    b   _fsm_exc_svc
    b   _fsm_exc_pabt
    b   _fsm_exc_dabt
    b   _fsm_exc_reserved
    b   _fsm_exc_irq
    b   _fsm_exc_fiq

_fsm_exc_und:
    mov r0, #1
    sub r1, lr, #4
    b   _fsm_exc_common
_fsm_exc_svc:
    /* A semihosting call (`svc #0x123456`, 0xEF123456) reaches this vector only when no
       debugger or QEMU `-semihosting` answers it: answer -1 in r0 and return (CPSR from SPSR,
       so the caller's flags too), so that the firmware can tell (`semihosting::host_present`)
       and talk over its UART instead. r0 is the call's result anyway; r1 is left alone. */
    ldr  r0, [lr, #-4]
    eor  r0, r0, #0xEF000000
    eor  r0, r0, #0x00120000
    eor  r0, r0, #0x00003400
    eors r0, r0, #0x00000056
    mvneq r0, #0
    movseq pc, lr
    mov r0, #2
    sub r1, lr, #4
    b   _fsm_exc_common
_fsm_exc_pabt:
    mov r0, #3
    sub r1, lr, #4
    b   _fsm_exc_common
_fsm_exc_dabt:
    mov r0, #4
    sub r1, lr, #8
    b   _fsm_exc_common
_fsm_exc_reserved:
    mov r0, #5
    mov r1, lr
    b   _fsm_exc_common
_fsm_exc_irq:
    mov r0, #6
    sub r1, lr, #4
    b   _fsm_exc_common
_fsm_exc_fiq:
    mov r0, #7
    sub r1, lr, #4
_fsm_exc_common:
    ldr sp, =_exc_stack_top
    mrs r2, spsr
    bl  fsm_fw_exception
1:  wfi
    b   1b

    .section .text._start, "ax", %progbits
    .arm
    .global _start
    .type _start, %function
_start:
    cpsid aif
    /* Only CPU 0 runs the firmware. */
    mrc p15, 0, r0, c0, c0, 5       /* MPIDR */
    ands r0, r0, #3
    bne _fsm_park

    cps #0x13                       /* SVC mode */
    ldr sp, =_stack_top

    /* SCTLR.V = 0: vectors at VBAR; also make sure the MMU is off until fsm_fw_init. */
    mrc p15, 0, r0, c1, c0, 0
    bic r0, r0, #(1 << 13)
    bic r0, r0, #1
    mcr p15, 0, r0, c1, c0, 0
    isb
    ldr r0, =_vectors
    mcr p15, 0, r0, c12, c0, 0      /* VBAR */
    isb

    /* VFP/NEON: CPACR cp10, cp11 full access (bits 20..23), then FPEXC.EN (bit 30). */
    mrc p15, 0, r0, c1, c0, 2
    orr r0, r0, #(0xf << 20)
    mcr p15, 0, r0, c1, c0, 2
    isb
    mov r0, #0x40000000
    vmsr fpexc, r0
    mov r0, #0
    vmsr fpscr, r0                  /* round-to-nearest, IEEE denormals, no traps */

    /* Zero .bss (8-byte aligned at both ends, see link.x). */
    ldr r0, =_sbss
    ldr r1, =_ebss
    mov r2, #0
2:  cmp r0, r1
    strlo r2, [r0], #4
    blo 2b

    /* Copy .data from its load address when it is not already in place. */
    ldr r0, =_sdata
    ldr r1, =_edata
    ldr r2, =_sidata
    cmp r0, r2
    beq 4f
3:  cmp r0, r1
    ldrlo r3, [r2], #4
    strlo r3, [r0], #4
    blo 3b
4:
    bl  fsm_fw_init
    bl  fw_main
    /* fw_main returns `!`; should it come back anyway, stop. */
_fsm_park:
    wfe
    b   _fsm_park
    .size _start, . - _start
"#
);
