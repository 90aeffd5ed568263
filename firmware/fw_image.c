/* The per-core runner: fixed-period ticks on simulated time through the HAL. */
#include "fw_image.h"

#include <string.h>

#include "hal/hal.h"

const fw_core_timing_t fw_core_timing_default[HAL_CORE_COUNT] = {
    [HAL_CORE_RT] = {FW_RT_PERIOD_US, FW_RT_SCAN_DIVIDER},
    [HAL_CORE_GP] = {FW_GP_PERIOD_US, 1u},
    [HAL_CORE_AI] = {FW_AI_PERIOD_US, 1u},
};

void fw_image_defaults(fw_image_t *img)
{
    if (img == NULL)
        return;
    memset(img, 0, sizeof(*img));
    for (int id = 0; id < HAL_CORE_COUNT; id++) {
        img->core[id].period_us = fw_core_timing_default[id].period_us;
        img->core[id].sub_divider = fw_core_timing_default[id].sub_divider;
    }
}

static const char *core_label(const fw_core_t *c, hal_core_id_t id)
{
    return c->name != NULL ? c->name : hal_core_name(id);
}

static void fw_core_entry(void *arg)
{
    fw_image_slot_t *slot = arg;
    const fw_core_t *c = &slot->image->core[slot->id];
    fw_core_stats_t *st = &slot->image->stats[slot->id];
    uint64_t start = 0;
    if (hal_clock_now_us(&start) != 0) {
        st->done = 1;
        return;
    }
    /* Released at whole periods of the board's clock (the host's lockstep starts at 0): a
       scheduler that wakes its threads on a tick dividing the period releases the core at the
       tick itself, and a world stepped in whole periods sees each tick at its own step. */
    start += (c->period_us - start % c->period_us) % c->period_us;
    st->start_us = start;
    if (c->asleep != NULL) {
        const int r = hal_clock_while_asleep(c->asleep, c->arg, c->asleep_every_us);
        if (r != 0 && r != -ENOTSUP) /* a board whose clock is real time does not need it */
            hal_log(HAL_LOG_WARN, "%s: no work while asleep (%d)", core_label(c, slot->id), r);
    }
    if (c->init != NULL) {
        int r = c->init(c->arg);
        if (r < 0) {
            st->init_error = r;
            st->done = 1;
            hal_log(HAL_LOG_ERROR, "%s: init failed (%d), core not running", core_label(c, slot->id), r);
            return;
        }
    }
    for (uint64_t k = 0;; k++) {
        uint64_t t = start + k * (uint64_t)c->period_us;
        int r = hal_sleep_until_us(t);
        if (r == -ECANCELED)
            break;
        if (r != 0) {
            hal_log(HAL_LOG_ERROR, "%s: sleep failed (%d), core stops", core_label(c, slot->id), r);
            st->last_error = r;
            break;
        }
        fw_tick_t tick = {.now_us = t, .index = k, .sub = (k % c->sub_divider) == 0u};
        r = c->tick(c->arg, &tick);
        st->ticks++;
        if (r == FW_CORE_DONE)
            break;
        if (r < 0) {
            st->errors++;
            st->last_error = r;
            if (st->errors <= FW_CORE_LOG_ERRORS)
                hal_log(HAL_LOG_WARN, "%s: tick %llu failed (%d)%s", core_label(c, slot->id),
                        (unsigned long long)k, r,
                        st->errors == FW_CORE_LOG_ERRORS ? "; further errors not logged" : "");
        }
    }
    st->done = 1;
}

int fw_image_start(fw_image_t *img)
{
    if (img == NULL)
        return -EINVAL;
    int any = 0;
    for (int i = 0; i < HAL_CORE_COUNT; i++) {
        const fw_core_t *c = &img->core[i];
        if (c->tick == NULL)
            continue;
        if (c->period_us == 0 || c->sub_divider == 0)
            return -EINVAL;
        any = 1;
    }
    if (!any)
        return -EINVAL;
    for (int i = 0; i < HAL_CORE_COUNT; i++) {
        if (img->core[i].tick == NULL)
            continue;
        memset(&img->stats[i], 0, sizeof(img->stats[i]));
        img->slot[i].image = img;
        img->slot[i].id = (hal_core_id_t)i;
        int r = hal_core_start((hal_core_id_t)i, fw_core_entry, &img->slot[i]);
        if (r != 0)
            return r;
    }
    return 0;
}
