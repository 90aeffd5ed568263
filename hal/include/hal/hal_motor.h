/* Wheel motors of a differential-drive robot.
 *
 * Two optional ways to command: wheel angular velocities (rad/s, positive drives forward)
 * or a body twist (v in m/s forward, omega in rad/s counter-clockwise). A board implements
 * at least one; the other wrapper then returns -ENOTSUP. The command holds until replaced.
 * Values must be finite (-EINVAL otherwise); the board may saturate them to its limits.
 *
 * Who may call: the RT core only. Non-blocking.
 */
#ifndef HAL_MOTOR_H
#define HAL_MOTOR_H

#include "hal/hal_board.h"

typedef struct hal_motor_ops {
    /* Optional. */
    int (*set_wheels)(void *ctx, float left_rad_s, float right_rad_s);
    /* Optional. */
    int (*set_twist)(void *ctx, float v_m_s, float omega_rad_s);
} hal_motor_ops_t;

/* x == x is false only for NaN; the bounds reject infinities (no <math.h> needed). */
static inline int hal_motor_finite_(float x)
{
    return x == x && x < 3.0e38f && x > -3.0e38f;
}

FS_MUST_CHECK static inline int hal_motor_set_wheels(float left_rad_s, float right_rad_s)
{
    const hal_board_t *b = hal_board_current;
    if (!hal_motor_finite_(left_rad_s) || !hal_motor_finite_(right_rad_s))
        return -EINVAL;
    if (b == NULL || b->motor == NULL)
        return -ENODEV;
    if (b->motor->set_wheels == NULL)
        return -ENOTSUP;
    return b->motor->set_wheels(b->ctx, left_rad_s, right_rad_s);
}

FS_MUST_CHECK static inline int hal_motor_set_twist(float v_m_s, float omega_rad_s)
{
    const hal_board_t *b = hal_board_current;
    if (!hal_motor_finite_(v_m_s) || !hal_motor_finite_(omega_rad_s))
        return -EINVAL;
    if (b == NULL || b->motor == NULL)
        return -ENODEV;
    if (b->motor->set_twist == NULL)
        return -ENOTSUP;
    return b->motor->set_twist(b->ctx, v_m_s, omega_rad_s);
}

#endif /* HAL_MOTOR_H */
