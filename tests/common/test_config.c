/* One build configuration per image: the sizes the firmware library was compiled with equal
 * the sizes this file sees, field by field, and (built for boards/host_alt) they are that
 * board's values, not the defaults. `make check-config` runs it for host_alt. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <cmocka.h>

#include "fw_config_sizes.h"
#include "rt/rt_grid.h"

#if defined(BOARD_HOST_ALT)
/* The board's values reached this file... */
_Static_assert(HAL_LIDAR_MAX_BEAMS == 180u && sizeof(((hal_lidar_scan_t *)0)->ranges_m) == 180u * sizeof(float),
               "host_alt: the lidar record has the board's beam count");
_Static_assert(FW_LINK_RING_CAPACITY == 4096u && AI_POOL_CAPACITY == (1u << 15) && GP_CORE_LOG_ROUNDS == 64u,
               "host_alt: ring, pool and round log follow the board");
_Static_assert(HAL_NET_MTU_BYTES == 8u * 1024u && DINNO_MAX_PEERS == 8u && BOARD_MAX_FLEET == 64u,
               "host_alt: MTU, neighbours and fleet");
_Static_assert(CRC32_SLICE8 == 0, "host_alt: the small CRC table");
_Static_assert(RT_GRID_MAX_CELLS == 16384 && RT_GRID_MAX_SIDE == 256 &&
                   sizeof(((rt_grid_t *)0)->occ) == 16384u,
               "host_alt: the RT core's grid follows the board");
#endif

static void test_library_and_program_agree(void **st)
{
    (void)st;
    const fw_config_sizes_t here = FW_CONFIG_SIZES_HERE, lib = fw_config_sizes;
    print_message("board %s: scan record %zu B (%u beams), rt %zu B, ai %zu B, gp %zu B, links %zu B, "
                  "mtu %zu B, peers %u of a fleet of %u, ring %u, pool %u, log %u\n",
                  BOARD_NAME, lib.lidar_scan_bytes, lib.lidar_beams, lib.rt_core_bytes,
                  lib.ai_core_bytes, lib.gp_core_bytes, lib.link_bytes, lib.net_mtu_bytes,
                  lib.max_peers, lib.max_fleet, lib.ring_capacity, lib.pool_capacity, lib.log_rounds);
    assert_int_equal(lib.lidar_scan_bytes, here.lidar_scan_bytes);
    assert_int_equal(lib.rt_core_bytes, here.rt_core_bytes);
    assert_int_equal(lib.ai_core_bytes, here.ai_core_bytes);
    assert_int_equal(lib.gp_core_bytes, here.gp_core_bytes);
    assert_int_equal(lib.link_bytes, here.link_bytes);
    assert_int_equal(lib.net_mtu_bytes, here.net_mtu_bytes);
    assert_int_equal(lib.lidar_beams, here.lidar_beams);
    assert_int_equal(lib.max_peers, here.max_peers);
    assert_int_equal(lib.max_fleet, here.max_fleet);
    assert_int_equal(lib.ring_capacity, here.ring_capacity);
    assert_int_equal(lib.pool_capacity, here.pool_capacity);
    assert_int_equal(lib.log_rounds, here.log_rounds);
    assert_int_equal(lib.max_waypoints, here.max_waypoints);
    assert_int_equal(lib.max_scan_samples, here.max_scan_samples);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_library_and_program_agree),
    };
    return cmocka_run_group_tests_name("common/config", tests, NULL, NULL);
}
