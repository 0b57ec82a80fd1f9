/* interrupt.c - the flag of interrupt.h */
#include "core/interrupt.h"

volatile sig_atomic_t nz_interrupt_pending = 0;
