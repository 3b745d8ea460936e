/*
 * Start-up for the C example on a Cortex-M7 under QEMU (mps2-an500): the vector table, the FPU,
 * .bss, newlib's semihosting I/O, and argv from the semihosting command line
 * (`qemu-system-arm ... -semihosting-config enable=on,target=native,arg=fuse,arg=VIS.pgm,...`).
 * QEMU loads .data at its run address, so nothing is copied from flash.
 */
#include <stdlib.h>
#include <string.h>

extern int main(int argc, char **argv);
extern void initialise_monitor_handles(void);
extern unsigned char __bss_start__[], __bss_end__[];
extern unsigned char __stack_top[];

/* One semihosting call (`bkpt 0xAB`, operation in r0, argument block in r1). */
static int semihost(int op, void *arg) {
  register int r0 __asm__("r0") = op;
  register void *r1 __asm__("r1") = arg;
  __asm__ volatile("bkpt 0xAB" : "+r"(r0) : "r"(r1) : "memory");
  return r0;
}

/* No constructors or destructors run here; newlib's exit() calls these. */
void _init(void) {}
void _fini(void) {}

/* Fault: report through semihosting and stop QEMU with a failure status. */
void Fault_Handler(void) {
  static const char msg[] = "fuse: fault\n";
  semihost(0x04, (void *)msg); /* SYS_WRITE0 */
  exit(1);
}

void Reset_Handler(void) {
  /* CP10/CP11 full access: the Rust core may use the FPU (eabihf). */
  *(volatile unsigned *)0xE000ED88 |= 0xFu << 20;
  __asm__ volatile("dsb\n isb");
  memset(__bss_start__, 0, (size_t)(__bss_end__ - __bss_start__));
  initialise_monitor_handles();

  static char cmdline[1024];
  static char *argv[16];
  struct {
    char *buf;
    int len;
  } block = {cmdline, (int)sizeof cmdline - 1};
  int argc = 0;
  if (semihost(0x15, &block) == 0) { /* SYS_GET_CMDLINE */
    cmdline[block.len] = '\0';
    for (char *p = strtok(cmdline, " "); p && argc < 15; p = strtok(NULL, " ")) argv[argc++] = p;
  }
  argv[argc] = NULL;
  exit(main(argc, argv));
}

__attribute__((section(".isr_vector"), used)) static void (*const vectors[16])(void) = {
    (void (*)(void))__stack_top, Reset_Handler, Fault_Handler, Fault_Handler, Fault_Handler, Fault_Handler,
    Fault_Handler, 0, 0, 0, 0, Fault_Handler, Fault_Handler, 0, Fault_Handler, Fault_Handler,
};
