/* The robot firmware image: the RT, AI and GP cores (rt_core, ai_core, gp_core) with their
 * static state and links (fw_link), started through fw_image on the installed HAL board.
 *
 * One image per process (all storage is static). fw_robot_start() resets every link and
 * core state, then starts the three cores; call it with the board installed and before the
 * board runs (on the host: after hal_board_install(), before hal_host_run_until()). It may
 * be called again for a new run once the previous board was stopped and destroyed.
 * The accessors give the cores' state for reading by the host while the lockstep holds every
 * core blocked, or after the cores stopped. */
#ifndef FW_ROBOT_H
#define FW_ROBOT_H

#include <stddef.h>

#include "ai/ai_core.h"
#include "fw_image.h"
#include "fw_link.h"
#include "gp/gp_core.h"
#include "gp/gp_fleet.h"
#include "rt/rt_core.h"

typedef struct fw_robot_cfg {
    rt_core_cfg_t rt;          /* rt.period_us is set from timing[HAL_CORE_RT] */
    ai_core_cfg_t ai;
    gp_core_cfg_t gp;
    fw_core_timing_t timing[HAL_CORE_COUNT]; /* default fw_core_timing_default */
} fw_robot_cfg_t;

/* Defaults for everything but the path and the plan box (rt.waypoints, rt.samples box). */
fw_robot_cfg_t fw_robot_default_cfg(void);

/* Makes the robot a member of a fleet (gp_fleet.h): initialises the image's fleet exchange from
 * fleet (the channels it names must be subscribable on the installed board) and points cfg's GP
 * core at it, with the AI core's posterior rounds and fleet size the fleet's. Before
 * fw_robot_start(). 0 or gp_fleet_init()'s error. */
FS_MUST_CHECK int fw_robot_join_fleet(fw_robot_cfg_t *cfg, const gp_fleet_cfg_t *fleet);

/* Initialises the cores from cfg and starts them. 0, -EINVAL (bad cfg) or the HAL's error. */
FS_MUST_CHECK int fw_robot_start(const fw_robot_cfg_t *cfg);

const rt_core_t *fw_robot_rt(void);
const ai_core_t *fw_robot_ai(void);
/* The AI core's state, writable, for a program that runs the AI core's work itself on a
 * board without cores (tools/board/board_train.c): it trains this core's own DiNNO node on
 * this core's own pool, so the image holds one model, not two. Not while the cores run. */
ai_core_t *fw_robot_ai_work(void);
gp_core_t *fw_robot_gp(void);
/* The GP core's fleet exchange (static, in the image's GP RAM), joined by fw_robot_join_fleet();
 * left unused by a robot without peers. */
gp_fleet_t *fw_robot_fleet(void);
const fw_image_t *fw_robot_image(void);

/* Static memory of the image, bytes (sizeof of each piece). */
typedef struct fw_robot_memory {
    size_t rt_state;        /* rt_core_t: waypoints, scan buffer, sample scratch, exploration state */
    size_t rt_links;        /* sample ring + RT status mailboxes */
    size_t ring;            /* of which: the sample ring */
    size_t ai_state;        /* ai_core_t total */
    size_t ai_node;         /* of which: the DiNNO node (model arena, duals, neighbour view, batch) */
    size_t ai_model_arena;  /* of which: the BNN arena */
    size_t ai_pool;         /* of which: the sample pool */
    size_t ai_links;        /* AI status, state and ckpt mailboxes */
    size_t gp_state;        /* gp_core_t (round log, telemetry buffer) */
    size_t gp_links;        /* ready mailbox + neighbour view */
    size_t gp_fleet;        /* gp_fleet_t: the fleet exchange (state buffers of two rounds) */
    size_t image;           /* fw_image_t */
} fw_robot_memory_t;

void fw_robot_memory(fw_robot_memory_t *m);

#endif /* FW_ROBOT_H */
