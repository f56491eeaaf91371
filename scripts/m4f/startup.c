/* A minimal Cortex-M4F start for QEMU's mps2-an386 (scripts/m4f-run.sh):
 * the vector table (initial stack pointer, reset handler), the FPU switched
 * on (CPACR: CP10 and CP11 full access) before any float instruction, .bss
 * zeroed, main called, and its status returned to QEMU by the semihosting
 * SYS_EXIT call (ADP_Stopped_ApplicationExit: QEMU exits 0; any other
 * reason: QEMU exits 1). Everything lives in the 4 MB SSRAM at address 0
 * (scripts/m4f/mps2-an386.ld), which QEMU loads from the ELF file. */
#include <stdint.h>

extern int main(void);
extern uint32_t __bss_start__, __bss_end__, __stack_top__;

static void semihost_exit(int status) {
    register int r0 __asm__("r0") = 0x18;                            /* SYS_EXIT */
    register int r1 __asm__("r1") = status == 0 ? 0x20026 : 0x20023; /* exit / run-time error */
    __asm__ volatile("bkpt 0xAB" : "+r"(r0) : "r"(r1) : "memory");
    for (;;) {
    }
}

void reset_handler(void) {
    volatile uint32_t *cpacr = (volatile uint32_t *)0xE000ED88u;
    uint32_t *p;
    *cpacr |= 0xFu << 20;
    __asm__ volatile("dsb\n\tisb" ::: "memory");
    for (p = &__bss_start__; p < &__bss_end__; p++) *p = 0;
    semihost_exit(main());
}

void fault_handler(void) {
    semihost_exit(3);
}

__attribute__((section(".vectors"), used)) static const uintptr_t vectors[16] = {
    (uintptr_t)&__stack_top__, (uintptr_t)reset_handler, (uintptr_t)fault_handler,
    (uintptr_t)fault_handler,  (uintptr_t)fault_handler, (uintptr_t)fault_handler,
    (uintptr_t)fault_handler,
};
