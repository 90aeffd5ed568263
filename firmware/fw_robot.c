/* The robot image: static cores and links, start-up. See fw_robot.h. */
#include "fw_robot.h"

#include <string.h>

static rt_core_t fw_rt;
static ai_core_t fw_ai;
static gp_core_t fw_gp;
static gp_fleet_t fw_fleet; /* the GP core's fleet exchange: its reassembly buffers hold the
                               neighbour states the AI core reads in place */
static fw_image_t fw_img;

_Static_assert(sizeof(gp_core_t) + sizeof(gp_fleet_t) + GP_LINK_BYTES <= BOARD_RAM_GP_BYTES,
               "GP core, its fleet exchange and its links exceed the board's GP RAM");

fw_robot_cfg_t fw_robot_default_cfg(void)
{
    fw_robot_cfg_t c;
    memset(&c, 0, sizeof c);
    c.rt.follow = rt_follow_default_cfg();
    c.rt.samples.n_beams = RT_SAMPLES_DEFAULT_BEAMS;
    c.rt.samples.points_per_beam = RT_SAMPLES_DEFAULT_POINTS;
    c.ai = ai_core_default_cfg();
    c.gp = gp_core_default_cfg();
    memcpy(c.timing, fw_core_timing_default, sizeof c.timing);
    return c;
}

int fw_robot_join_fleet(fw_robot_cfg_t *cfg, const gp_fleet_cfg_t *fleet)
{
    if (cfg == NULL || fleet == NULL)
        return -EINVAL;
    const int r = gp_fleet_init(&fw_fleet, fleet);
    if (r != 0)
        return r;
    cfg->gp.peers = &gp_fleet_peers_ops;
    cfg->gp.peers_ctx = &fw_fleet;
    cfg->ai.post_rounds = fleet->post_rounds; /* the fleet's posterior, after the DiNNO rounds */
    cfg->ai.fleet_size = fleet->n_peers;
    return 0;
}

int fw_robot_start(const fw_robot_cfg_t *cfg)
{
    if (cfg == NULL)
        return -EINVAL;
    for (int id = 0; id < HAL_CORE_COUNT; id++)
        if (cfg->timing[id].period_us == 0 || cfg->timing[id].sub_divider == 0)
            return -EINVAL;
    fw_link_reset();
    const fw_link_t *link = fw_link_get();
    rt_core_cfg_t rc = cfg->rt;
    rc.period_us = cfg->timing[HAL_CORE_RT].period_us;
    int r = rt_core_init(&fw_rt, &rc, link);
    if (r == 0)
        r = ai_core_init(&fw_ai, &cfg->ai, link);
    if (r == 0)
        r = gp_core_init(&fw_gp, &cfg->gp, link);
    if (r != 0)
        return r;
    fw_image_defaults(&fw_img);
    static const struct {
        fw_core_tick_fn tick;
        void *arg;
    } loop[HAL_CORE_COUNT] = {
        [HAL_CORE_RT] = {rt_core_tick, &fw_rt},
        [HAL_CORE_GP] = {gp_core_tick, &fw_gp},
        [HAL_CORE_AI] = {ai_core_tick, &fw_ai},
    };
    for (int id = 0; id < HAL_CORE_COUNT; id++)
        fw_img.core[id] = (fw_core_t){.name = hal_core_name((hal_core_id_t)id),
                                      .period_us = cfg->timing[id].period_us,
                                      .sub_divider = cfg->timing[id].sub_divider,
                                      .tick = loop[id].tick,
                                      .arg = loop[id].arg};
    /* The network runs in real time: the GP core serves it while the AI core trains. */
    fw_img.core[HAL_CORE_GP].asleep = gp_core_asleep;
    fw_img.core[HAL_CORE_GP].asleep_every_us = GP_CORE_ASLEEP_EVERY_US;
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

ai_core_t *fw_robot_ai_work(void)
{
    return &fw_ai;
}

gp_core_t *fw_robot_gp(void)
{
    return &fw_gp;
}

gp_fleet_t *fw_robot_fleet(void)
{
    return &fw_fleet;
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
    m->rt_links = RT_LINK_BYTES;
    m->ring = RING_STORAGE_BYTES(sizeof(ai_sample_t), FW_LINK_RING_CAPACITY);
    m->ai_state = sizeof(ai_core_t);
    m->ai_node = sizeof(dinno_node_t);
    m->ai_model_arena = BNN_ARENA_BYTES;
    m->ai_pool = sizeof(ai_sample_t) * (size_t)AI_POOL_CAPACITY;
    m->ai_links = AI_LINK_BYTES;
    m->gp_state = sizeof(gp_core_t);
    m->gp_links = GP_LINK_BYTES;
    m->gp_fleet = sizeof(gp_fleet_t);
    m->image = sizeof(fw_image_t);
}
