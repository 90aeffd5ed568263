/* Every HAL interface. Firmware includes this (or the single interfaces it uses). */
#ifndef HAL_HAL_H
#define HAL_HAL_H

#include "hal/hal_board.h"
#include "hal/hal_clock.h"
#include "hal/hal_core.h"
#include "hal/hal_lidar.h"
#include "hal/hal_log.h"
#include "hal/hal_motor.h"
#include "hal/hal_net.h"
#include "hal/hal_pose.h"
#include "hal/hal_storage.h"

#endif /* HAL_HAL_H */
