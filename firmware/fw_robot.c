/* The robot image: static cores and links, start-up. See fw_robot.h. */
#include "fw_robot.h"

#include <string.h>

static rt_core_t fw_rt;
static ai_core_t fw_ai;
static gp_core_t fw_gp;
static fw_image_t fw_img;

fw_robot_cfg_t fw_robot_default_cfg(void)
{
    fw_robot_cfg_t c;
    memset(&c, 0, sizeof c);
    c.rt.follow = rt_follow_default_cfg();
    c.rt.samples.n_beams = RT_SAMPLES_DEFAULT_BEAMS;
    c.rt.samples.points_per_beam = RT_SAMPLES_DEFAULT_POINTS;
    c.ai = ai_core_default_cfg();
    c.gp = gp_core_default_cfg();
    c.rt_period_us = FW_RT_PERIOD_US;
    c.rt_scan_divider = FW_RT_SCAN_DIVIDER;
    c.gp_period_us = FW_GP_PERIOD_US;
    c.ai_period_us = FW_AI_PERIOD_US;
    return c;
}

int fw_robot_start(const fw_robot_cfg_t *cfg)
{
    if (cfg == NULL || cfg->rt_period_us == 0 || cfg->rt_scan_divider == 0 ||
        cfg->gp_period_us == 0 || cfg->ai_period_us == 0)
        return -EINVAL;
    fw_link_reset();
    const fw_link_t *link = fw_link_get();
    rt_core_cfg_t rc = cfg->rt;
    rc.period_us = cfg->rt_period_us;
    int r = rt_core_init(&fw_rt, &rc, link);
    if (r == 0)
        r = ai_core_init(&fw_ai, &cfg->ai, link);
    if (r == 0)
        r = gp_core_init(&fw_gp, &cfg->gp, link);
    if (r != 0)
        return r;
    fw_image_defaults(&fw_img);
    fw_img.core[HAL_CORE_RT] = (fw_core_t){"RT", cfg->rt_period_us, cfg->rt_scan_divider, NULL,
                                           rt_core_tick, &fw_rt};
    fw_img.core[HAL_CORE_GP] = (fw_core_t){"GP", cfg->gp_period_us, 1u, NULL, gp_core_tick, &fw_gp};
    fw_img.core[HAL_CORE_AI] = (fw_core_t){"AI", cfg->ai_period_us, 1u, NULL, ai_core_tick, &fw_ai};
    return fw_image_start(&fw_img);
}

const rt_core_t *fw_robot_rt(void)
{
    return &fw_rt;
}

const ai_core_t *fw_robot_ai(void)
{
    return &fw_ai;
}

gp_core_t *fw_robot_gp(void)
{
    return &fw_gp;
}

const fw_image_t *fw_robot_image(void)
{
    return &fw_img;
}

void fw_robot_memory(fw_robot_memory_t *m)
{
    if (m == NULL)
        return;
    m->rt_state = sizeof(rt_core_t);
    m->rt_links = FW_LINK_RT_BYTES;
    m->ring = RING_STORAGE_BYTES(sizeof(ai_sample_t), FW_LINK_RING_CAPACITY);
    m->ai_state = sizeof(ai_core_t);
    m->ai_node = sizeof(dinno_node_t);
    m->ai_model_arena = BNN_ARENA_BYTES;
    m->ai_pool = sizeof(ai_sample_t) * (size_t)AI_POOL_CAPACITY;
    m->ai_links = FW_LINK_AI_BYTES;
    m->gp_state = sizeof(gp_core_t);
    m->gp_links = FW_LINK_GP_BYTES;
    m->image = sizeof(fw_image_t);
}
