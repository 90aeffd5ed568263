/* Between the Cortex-M target's start-up (hal_stdc_cortex_m.c: vectors, SysTick) and its
 * scheduler (hal_stdc_cortex_m_cores.c). */
#ifndef HAL_STDC_CORTEX_M_CORES_H
#define HAL_STDC_CORTEX_M_CORES_H

#include <stdint.h>

/* Scheduler ticks per second: how late at most a sleeping core wakes (100 us), against the
 * interrupt's cost (tens of instructions per tick). */
#define HAL_STDC_CM_TICK_HZ 10000u

/* The SysTick interrupt, after the time base moved on: wakes the threads whose time came. */
void hal_stdc_cm_tick(uint64_t now_us);

/* The PendSV handler: switches to the highest thread ready. */
void hal_stdc_cm_pendsv(void);

/* The thread running, for a fault's message ("RT core", "main program", ...). */
const char *hal_stdc_cm_thread_name(void);

#endif /* HAL_STDC_CORTEX_M_CORES_H */
