/* ODE world: walls from a plan, a floor, differential-drive robots. Contract in sim_world.h.
 *
 * Design notes (the why):
 * - Wheels are spheres, not cylinders: a sphere has one contact point with the floor, which
 *   rolls smoothly and is cheaper and more stable under dWorldQuickStep than the 2-4 edge
 *   contacts of a cylinder; the kinematics (radius, separation) are the same.
 * - The caster is a second geom on the chassis body with zero friction: it carries weight
 *   and never resists motion, which is all a ball caster does.
 * - Collision pairs are enumerated explicitly each step (robot geoms vs floor plane, the
 *   robot space vs the wall space, robots vs robots) rather than with one generic
 *   dSpaceCollide over a hierarchy: walls never collide with walls, so we never pay for it.
 * - Walls are static geoms (no body). Non-rectangular solids become closed extruded
 *   trimeshes so that robots (box/sphere vs trimesh) and rays (ray vs trimesh) both work.
 */
#include "sim_world.h"

#include <errno.h>
#include <math.h>
#include <pthread.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "rt/rt_follow.h"
#include "sim_shape.h"

#define MAX_CONTACTS 8

enum { KIND_CHASSIS = 0, KIND_WHEEL_L, KIND_WHEEL_R, KIND_CASTER, KIND_COUNT };

typedef struct geom_tag {
    int robot; /* index, or -1 for a wall */
    int kind;
} geom_tag_t;

typedef struct robot {
    sim_robot_params_t p;
    dBodyID chassis, wheel[2];
    dJointID hinge[2];
    dGeomID geom[KIND_COUNT];
    geom_tag_t tag[KIND_COUNT];
    int touching_now;
    double last_touch; /* simulated time of the last wall contact, -inf before any */
    uint64_t collisions;
} robot_t;

typedef struct trimesh {
    dTriMeshDataID data;
    double *verts;
    dTriIndex *idx;
} trimesh_t;

struct sim_world {
    sim_world_cfg_t cfg;
    dWorldID world;
    dSpaceID walls;  /* quadtree: static wall geoms only */
    dSpaceID robots; /* simple space: every robot geom */
    dGeomID floor;
    dJointGroupID contacts;
    dGeomID *wall_geoms;
    int n_walls;
    trimesh_t *meshes;
    int n_meshes;
    robot_t **robot;
    int n_robots, cap_robots;
    geom_tag_t wall_tag;
    double time;
    unsigned long rand_seed; /* this world's state of ODE's global dRand (see step) */
    sim_vec2_t min, max;
};

/* ---- process-wide ODE initialisation ---------------------------------------------------- */
static pthread_once_t ode_once = PTHREAD_ONCE_INIT;
static int ode_ok;

static void ode_close(void) { dCloseODE(); }

static void ode_init(void)
{
    ode_ok = dInitODE2(0) != 0;
    if (ode_ok)
        atexit(ode_close);
}

static int ode_ready(char *err, size_t errlen)
{
    pthread_once(&ode_once, ode_init);
    if (!ode_ok) {
        snprintf(err, errlen, "ODE initialisation (dInitODE2) failed");
        return -EIO;
    }
    if (!dCheckConfiguration("ODE_double_precision")) {
        snprintf(err, errlen, "libode is not built in double precision");
        return -ENOTSUP;
    }
    /* Per-thread collision data for the calling thread (idempotent). */
    if (!dAllocateODEDataForThread(dAllocateMaskAll)) {
        snprintf(err, errlen, "ODE per-thread data allocation failed");
        return -ENOMEM;
    }
    return 0;
}

int sim_world_thread_init(void)
{
    char err[128];
    return ode_ready(err, sizeof err);
}

/* ---- defaults ---------------------------------------------------------------------------- */
sim_world_cfg_t sim_world_default_cfg(void)
{
    sim_world_cfg_t c = {
        .dt = 0.01,
        .wall_height = 2.5,
        .gravity = 9.81,
        .solver_iterations = 0,
        .mu_wheel = 1.0,
        .mu_wall = 0.3,
    };
    return c;
}

sim_robot_params_t sim_robot_default_params(void)
{
    sim_robot_params_t p = {
        .base_length = 0.14,
        .base_width = 0.18,
        .base_height = 0.14,
        .chassis_offset_x = -0.032,
        .chassis_mass = 0.8,
        .wheel_radius = 0.033,
        .wheel_separation = 0.160,
        .wheel_mass = 0.1,
        .caster_radius = 0.02,
        .caster_offset_x = -0.081,
        .v_max = 0.22,
        .w_max = 2.84,
        .motor_fmax = 1.0,
    };
    return p;
}

static int pos(double v) { return isfinite(v) && v > 0.0; }

/* ---- walls ------------------------------------------------------------------------------- */
static int add_box_wall(sim_world_t *w, const sim_poly_t *o, double height)
{
    /* Rectangle: centre = mean of the corners, sides from two consecutive edges. */
    double cx = 0, cy = 0;
    for (int i = 0; i < 4; i++) {
        cx += o->p[i].x * 0.25;
        cy += o->p[i].y * 0.25;
    }
    double ax = o->p[1].x - o->p[0].x, ay = o->p[1].y - o->p[0].y;
    double bx = o->p[2].x - o->p[1].x, by = o->p[2].y - o->p[1].y;
    double la = hypot(ax, ay), lb = hypot(bx, by);
    if (!(la > 1e-9 && lb > 1e-9))
        return -EINVAL;
    dGeomID g = dCreateBox(w->walls, la, lb, height);
    dGeomSetPosition(g, cx, cy, 0.5 * height);
    dMatrix3 R;
    dRFromAxisAndAngle(R, 0, 0, 1, atan2(ay, ax));
    dGeomSetRotation(g, R);
    dGeomSetData(g, &w->wall_tag);
    w->wall_geoms[w->n_walls++] = g;
    return 0;
}

static int add_mesh_wall(sim_world_t *w, const sim_poly_t *o, double height)
{
    int n = o->n;
    int tris[SIM_POLY_MAX_POINTS][3];
    int nt = sim_shape_triangulate(o, tris, SIM_POLY_MAX_POINTS);
    if (nt < 1)
        return -EINVAL;
    int ccw = sim_shape_area(o) > 0.0;
    trimesh_t *m = &w->meshes[w->n_meshes];
    m->verts = malloc(sizeof(double) * 3 * (size_t)(2 * n));
    m->idx = malloc(sizeof(dTriIndex) * 3 * (size_t)(2 * nt + 2 * n));
    if (m->verts == NULL || m->idx == NULL) {
        free(m->verts);
        free(m->idx);
        return -ENOMEM;
    }
    /* Vertices in counter-clockwise order: i = bottom, n + i = top. */
    for (int i = 0; i < n; i++) {
        const sim_vec2_t *q = &o->p[ccw ? i : n - 1 - i];
        double *b = &m->verts[3 * i], *t = &m->verts[3 * (n + i)];
        b[0] = t[0] = q->x;
        b[1] = t[1] = q->y;
        b[2] = 0.0;
        t[2] = height;
    }
    int k = 0;
    for (int i = 0; i < nt; i++) {
        /* triangulate() indexes the original order; map to the CCW vertex numbering. */
        int a = tris[i][0], b = tris[i][1], c = tris[i][2];
        if (!ccw) {
            a = n - 1 - a;
            b = n - 1 - b;
            c = n - 1 - c;
        }
        m->idx[k++] = (dTriIndex)(n + a); /* top cap, normal +z */
        m->idx[k++] = (dTriIndex)(n + b);
        m->idx[k++] = (dTriIndex)(n + c);
        m->idx[k++] = (dTriIndex)c; /* bottom cap, normal -z */
        m->idx[k++] = (dTriIndex)b;
        m->idx[k++] = (dTriIndex)a;
    }
    for (int i = 0; i < n; i++) {
        int j = (i + 1) % n; /* side quad, outward normal for a CCW outline */
        m->idx[k++] = (dTriIndex)i;
        m->idx[k++] = (dTriIndex)j;
        m->idx[k++] = (dTriIndex)(n + j);
        m->idx[k++] = (dTriIndex)i;
        m->idx[k++] = (dTriIndex)(n + j);
        m->idx[k++] = (dTriIndex)(n + i);
    }
    m->data = dGeomTriMeshDataCreate();
    dGeomTriMeshDataBuildDouble(m->data, m->verts, 3 * sizeof(double), 2 * n, m->idx, k,
                                3 * sizeof(dTriIndex));
    w->n_meshes++;
    dGeomID g = dCreateTriMesh(w->walls, m->data, NULL, NULL, NULL);
    dGeomSetData(g, &w->wall_tag);
    w->wall_geoms[w->n_walls++] = g;
    return 0;
}

int sim_world_create(const sim_plan_t *plan, const sim_world_cfg_t *cfg, sim_world_t **out,
                     char *err, size_t errlen)
{
    char dummy[2];
    if (err == NULL || errlen == 0) {
        err = dummy;
        errlen = sizeof dummy;
    }
    if (out == NULL || plan == NULL || (plan->n_solids > 0 && plan->solids == NULL) ||
        plan->n_solids < 0) {
        snprintf(err, errlen, "sim_world_create: bad arguments");
        return -EINVAL;
    }
    *out = NULL;
    sim_world_cfg_t c = cfg ? *cfg : sim_world_default_cfg();
    if (!pos(c.dt) || c.dt > 0.05 || !pos(c.wall_height) || !isfinite(c.gravity) ||
        c.gravity < 0 || c.solver_iterations < 0 || c.solver_iterations > 1000 || isnan(c.mu_wheel) || c.mu_wheel < 0 ||
        !isfinite(c.mu_wall) || c.mu_wall < 0) {
        snprintf(err, errlen, "sim_world_create: invalid configuration (dt in (0, 0.05], "
                              "positive wall height, non-negative gravity and friction)");
        return -EINVAL;
    }
    if (!isfinite(plan->min.x) || !isfinite(plan->min.y) || !isfinite(plan->max.x) ||
        !isfinite(plan->max.y) || !(plan->max.x > plan->min.x) || !(plan->max.y > plan->min.y)) {
        snprintf(err, errlen, "sim_world_create: plan has an empty or invalid bounding box");
        return -EINVAL;
    }
    int rc = ode_ready(err, errlen);
    if (rc < 0)
        return rc;

    sim_world_t *w = calloc(1, sizeof *w);
    if (w == NULL) {
        snprintf(err, errlen, "out of memory");
        return -ENOMEM;
    }
    w->cfg = c;
    w->min = plan->min;
    w->max = plan->max;
    w->wall_tag.robot = -1;
    w->rand_seed = 0x5EEDu;
    w->world = dWorldCreate();
    dWorldSetGravity(w->world, 0, 0, -c.gravity);
    if (c.solver_iterations > 0)
        dWorldSetQuickStepNumIterations(w->world, c.solver_iterations);
    dWorldSetERP(w->world, 0.2);
    dWorldSetCFM(w->world, 1e-6);
    dWorldSetContactSurfaceLayer(w->world, 0.0005);
    dWorldSetContactMaxCorrectingVel(w->world, 1.0);

    /* Quadtree over the plan: depth chosen so leaf blocks are about 1 m across. */
    dVector3 centre = {0.5 * (plan->min.x + plan->max.x), 0.5 * (plan->min.y + plan->max.y),
                       0.5 * c.wall_height, 0};
    dVector3 ext = {0.5 * (plan->max.x - plan->min.x) + 1.0,
                    0.5 * (plan->max.y - plan->min.y) + 1.0, 0.5 * c.wall_height + 1.0, 0};
    double span = fmax(ext[0], ext[1]) * 2.0;
    int depth = 1;
    while (depth < 7 && span / (double)(1 << depth) > 1.0)
        depth++;
    w->walls = dQuadTreeSpaceCreate(0, centre, ext, depth);
    w->robots = dSimpleSpaceCreate(0);
    w->floor = dCreatePlane(0, 0, 0, 1, 0);
    dGeomSetData(w->floor, &w->wall_tag);
    w->contacts = dJointGroupCreate(0);

    int ns = plan->n_solids;
    w->wall_geoms = calloc((size_t)(ns > 0 ? ns : 1), sizeof(dGeomID));
    w->meshes = calloc((size_t)(ns > 0 ? ns : 1), sizeof(trimesh_t));
    if (w->wall_geoms == NULL || w->meshes == NULL) {
        sim_world_destroy(w);
        snprintf(err, errlen, "out of memory");
        return -ENOMEM;
    }
    for (int i = 0; i < ns; i++) {
        const sim_solid_t *s = &plan->solids[i];
        if (s->outline.n < 3 || s->outline.n > SIM_POLY_MAX_POINTS) {
            sim_world_destroy(w);
            snprintf(err, errlen, "solid %d has %d points (3..%d expected)", i, s->outline.n,
                     SIM_POLY_MAX_POINTS);
            return -EINVAL;
        }
        /* A solid of its own height (a railing) is no higher than the walls, so a world of
         * low walls (a cut-away) stays one level. */
        double h = s->height > 0.0 ? fmin(s->height, c.wall_height) : c.wall_height;
        rc = (s->is_rect && s->outline.n == 4) ? add_box_wall(w, &s->outline, h)
                                                : add_mesh_wall(w, &s->outline, h);
        if (rc < 0) {
            sim_world_destroy(w);
            snprintf(err, errlen, "solid %d: %s", i,
                     rc == -ENOMEM ? "out of memory" : "degenerate outline, cannot build a geom");
            return rc;
        }
    }
    *out = w;
    return 0;
}

static void robot_free(robot_t *r)
{
    if (r == NULL)
        return;
    for (int k = 0; k < KIND_COUNT; k++)
        if (r->geom[k])
            dGeomDestroy(r->geom[k]);
    free(r);
}

void sim_world_destroy(sim_world_t *w)
{
    if (w == NULL)
        return;
    for (int i = 0; i < w->n_robots; i++)
        robot_free(w->robot[i]);
    free(w->robot);
    for (int i = 0; i < w->n_walls; i++)
        dGeomDestroy(w->wall_geoms[i]);
    for (int i = 0; i < w->n_meshes; i++) {
        dGeomTriMeshDataDestroy(w->meshes[i].data);
        free(w->meshes[i].verts);
        free(w->meshes[i].idx);
    }
    free(w->wall_geoms);
    free(w->meshes);
    if (w->floor)
        dGeomDestroy(w->floor);
    if (w->contacts)
        dJointGroupDestroy(w->contacts);
    if (w->robots)
        dSpaceDestroy(w->robots);
    if (w->walls)
        dSpaceDestroy(w->walls);
    if (w->world)
        dWorldDestroy(w->world); /* destroys the bodies and joints too */
    free(w);
}

/* ---- robots ------------------------------------------------------------------------------ */
static int params_ok(const sim_robot_params_t *p)
{
    return pos(p->base_length) && pos(p->base_width) && pos(p->base_height) &&
           isfinite(p->chassis_offset_x) && pos(p->chassis_mass) && pos(p->wheel_radius) &&
           pos(p->wheel_separation) && pos(p->wheel_mass) && pos(p->caster_radius) &&
           isfinite(p->caster_offset_x) && pos(p->v_max) && pos(p->w_max) &&
           pos(p->motor_fmax) && p->caster_radius < p->wheel_radius * 2.0 &&
           p->caster_radius <= p->base_height;
}

int sim_world_add_robot(sim_world_t *w, const sim_robot_params_t *params, sim_pose_t pose,
                        int *id)
{
    sim_robot_params_t p = params ? *params : sim_robot_default_params();
    if (w == NULL || id == NULL || !params_ok(&p) || !isfinite(pose.x) || !isfinite(pose.y) ||
        !isfinite(pose.theta))
        return -EINVAL;
    if (w->n_robots == w->cap_robots) {
        int cap = w->cap_robots ? 2 * w->cap_robots : 8;
        robot_t **nr = realloc(w->robot, sizeof(robot_t *) * (size_t)cap);
        if (nr == NULL)
            return -ENOMEM;
        w->robot = nr;
        w->cap_robots = cap;
    }
    robot_t *r = calloc(1, sizeof *r);
    if (r == NULL)
        return -ENOMEM;
    r->p = p;
    r->last_touch = -INFINITY;
    int idx = w->n_robots;
    double c = cos(pose.theta), s = sin(pose.theta);
    dMatrix3 R;
    dRFromAxisAndAngle(R, 0, 0, 1, pose.theta);

    /* Chassis: the caster touches the floor, so the chassis bottom sits at 2 * caster
     * radius minus nothing: caster centre at z = caster_radius, chassis bottom there too. */
    double zc = p.caster_radius + 0.5 * p.base_height;
    r->chassis = dBodyCreate(w->world);
    dBodySetPosition(r->chassis, pose.x + c * p.chassis_offset_x, pose.y + s * p.chassis_offset_x,
                     zc);
    dBodySetRotation(r->chassis, R);
    dMass m;
    dMassSetBoxTotal(&m, p.chassis_mass, p.base_length, p.base_width, p.base_height);
    dBodySetMass(r->chassis, &m);
    r->geom[KIND_CHASSIS] = dCreateBox(w->robots, p.base_length, p.base_width, p.base_height);
    dGeomSetBody(r->geom[KIND_CHASSIS], r->chassis);
    r->geom[KIND_CASTER] = dCreateSphere(w->robots, p.caster_radius);
    dGeomSetBody(r->geom[KIND_CASTER], r->chassis);
    dGeomSetOffsetPosition(r->geom[KIND_CASTER], p.caster_offset_x - p.chassis_offset_x, 0,
                           p.caster_radius - zc);

    for (int k = 0; k < 2; k++) {
        double side = k == 0 ? 0.5 : -0.5; /* left wheel at +y */
        double oy = side * p.wheel_separation;
        double wx = pose.x - s * oy, wy = pose.y + c * oy;
        r->wheel[k] = dBodyCreate(w->world);
        dBodySetPosition(r->wheel[k], wx, wy, p.wheel_radius);
        dBodySetRotation(r->wheel[k], R);
        dMassSetSphereTotal(&m, p.wheel_mass, p.wheel_radius);
        dBodySetMass(r->wheel[k], &m);
        r->geom[KIND_WHEEL_L + k] = dCreateSphere(w->robots, p.wheel_radius);
        dGeomSetBody(r->geom[KIND_WHEEL_L + k], r->wheel[k]);
        r->hinge[k] = dJointCreateHinge(w->world, 0);
        dJointAttach(r->hinge[k], r->chassis, r->wheel[k]);
        dJointSetHingeAnchor(r->hinge[k], wx, wy, p.wheel_radius);
        /* ODE measures the hinge rate of body 1 (chassis) relative to body 2 (wheel), so the
         * axis is robot -y for a positive motor speed to roll the wheel forward. */
        dJointSetHingeAxis(r->hinge[k], s, -c, 0);
        dJointSetHingeParam(r->hinge[k], dParamVel, 0.0);
        dJointSetHingeParam(r->hinge[k], dParamFMax, p.motor_fmax);
    }
    for (int k = 0; k < KIND_COUNT; k++) {
        r->tag[k].robot = idx;
        r->tag[k].kind = k;
        dGeomSetData(r->geom[k], &r->tag[k]);
    }
    w->robot[w->n_robots++] = r;
    *id = idx;
    return 0;
}

static robot_t *get(const sim_world_t *w, int id)
{
    if (w == NULL || id < 0 || id >= w->n_robots)
        return NULL;
    return w->robot[id];
}

int sim_world_set_wheels(sim_world_t *w, int id, double left, double right)
{
    robot_t *r = get(w, id);
    if (r == NULL || !isfinite(left) || !isfinite(right))
        return -EINVAL;
    double lim = r->p.v_max / r->p.wheel_radius;
    left = fmax(-lim, fmin(lim, left));
    right = fmax(-lim, fmin(lim, right));
    dJointSetHingeParam(r->hinge[0], dParamVel, left);
    dJointSetHingeParam(r->hinge[1], dParamVel, right);
    dBodyEnable(r->chassis);
    return 0;
}

int sim_world_set_twist(sim_world_t *w, int id, double v, double omega)
{
    robot_t *r = get(w, id);
    if (r == NULL)
        return -EINVAL;
    float l, rr;
    int rc = rt_follow_wheels((float)v, (float)fmax(-r->p.w_max, fmin(r->p.w_max, omega)),
                              (float)r->p.wheel_radius, (float)r->p.wheel_separation,
                              (float)(r->p.v_max / r->p.wheel_radius), &l, &rr);
    if (rc < 0)
        return rc;
    return sim_world_set_wheels(w, id, l, rr);
}

/* ---- stepping ---------------------------------------------------------------------------- */
static void add_contacts(sim_world_t *w, dGeomID a, dGeomID b)
{
    dContact ct[MAX_CONTACTS];
    int n = dCollide(a, b, MAX_CONTACTS, &ct[0].geom, sizeof(dContact));
    if (n <= 0)
        return;
    const geom_tag_t *ta = dGeomGetData(a), *tb = dGeomGetData(b);
    int floor_pair = a == w->floor || b == w->floor;
    const geom_tag_t *rt = ta->robot >= 0 ? ta : tb; /* the robot side, if any */
    double mu = w->cfg.mu_wall;
    int mode = dContactSoftERP | dContactSoftCFM;
    if (floor_pair) {
        if (rt->kind == KIND_WHEEL_L || rt->kind == KIND_WHEEL_R) {
            mu = w->cfg.mu_wheel;
            if (isinf(mu))
                mu = dInfinity; /* no-slip rolling: unbounded friction rows */
            else
                mode |= dContactApprox1;
        } else {
            mu = 0.0; /* caster (or a tipped chassis): slides freely */
        }
    } else if (ta->robot >= 0 && tb->robot >= 0) {
        mu = w->cfg.mu_wall; /* robot against robot */
    } else if (rt->robot >= 0) {
        w->robot[rt->robot]->touching_now = 1;
    }
    for (int i = 0; i < n; i++) {
        ct[i].surface.mode = mode;
        ct[i].surface.mu = mu;
        ct[i].surface.soft_erp = 0.8;
        ct[i].surface.soft_cfm = 1e-5;
        dJointID j = dJointCreateContact(w->world, w->contacts, &ct[i]);
        dJointAttach(j, dGeomGetBody(ct[i].geom.g1), dGeomGetBody(ct[i].geom.g2));
    }
}

static void near_cb(void *data, dGeomID a, dGeomID b)
{
    sim_world_t *w = data;
    dBodyID ba = dGeomGetBody(a), bb = dGeomGetBody(b);
    if (ba != NULL && bb != NULL && (ba == bb || dAreConnected(ba, bb)))
        return; /* parts of one robot */
    add_contacts(w, a, b);
}

int sim_world_step(sim_world_t *w, int n_steps)
{
    if (w == NULL || n_steps < 0)
        return -EINVAL;
    for (int s = 0; s < n_steps; s++) {
        for (int i = 0; i < w->n_robots; i++) {
            robot_t *r = w->robot[i];
            r->touching_now = 0;
            for (int k = 0; k < KIND_COUNT; k++)
                if (k != KIND_CHASSIS) /* the chassis rides above the floor */
                    add_contacts(w, r->geom[k], w->floor);
        }
        if (w->n_walls > 0 && w->n_robots > 0)
            dSpaceCollide2((dGeomID)w->robots, (dGeomID)w->walls, w, near_cb);
        if (w->n_robots > 1)
            dSpaceCollide(w->robots, w, near_cb);
        /* The exact solver (dWorldStep, Dantzig LCP) is the default: for 3 bodies and ~20
         * constraint rows per robot it costs about the same as dWorldQuickStep and tracks
         * motor speeds exactly, where 20 quickstep iterations leave ~1% error on wheel rates.
         * dWorldQuickStep randomly reorders constraints with ODE's process-global dRand.
         * Swapping this world's own seed in and out makes every world's trajectory depend
         * only on its own history (determinism); it also means two threads must not step
         * worlds at the same time (the contract in sim_world.h). */
        dRandSetSeed(w->rand_seed);
        if (w->cfg.solver_iterations == 0)
            dWorldStep(w->world, w->cfg.dt);
        else
            dWorldQuickStep(w->world, w->cfg.dt);
        w->rand_seed = dRandGetSeed();
        dJointGroupEmpty(w->contacts);
        w->time += w->cfg.dt;
        for (int i = 0; i < w->n_robots; i++) {
            robot_t *r = w->robot[i];
            /* A robot pressing on a wall makes and breaks contact from step to step; one
             * collision is counted per contact episode: contact after at least
             * SIM_WORLD_COLLISION_GAP_S without any. */
            if (r->touching_now) {
                if (w->time - r->last_touch > SIM_WORLD_COLLISION_GAP_S)
                    r->collisions++;
                r->last_touch = w->time;
            }
            const dReal *p = dBodyGetPosition(r->chassis);
            if (!isfinite(p[0]) || !isfinite(p[1]) || !isfinite(p[2]))
                return -EIO;
        }
    }
    return 0;
}

int sim_world_pose(const sim_world_t *w, int id, sim_pose_t *pose)
{
    robot_t *r = get(w, id);
    if (r == NULL || pose == NULL)
        return -EINVAL;
    const dReal *p = dBodyGetPosition(r->chassis);
    const dReal *R = dBodyGetRotation(r->chassis); /* row-major 3x4 */
    double yaw = atan2(R[4], R[0]);
    /* Base frame = chassis centre moved back to the wheel axis along the body x axis. */
    pose->x = p[0] - R[0] * r->p.chassis_offset_x;
    pose->y = p[1] - R[4] * r->p.chassis_offset_x;
    pose->theta = yaw;
    return 0;
}

int sim_world_wheel_rates(const sim_world_t *w, int id, double *left, double *right)
{
    robot_t *r = get(w, id);
    if (r == NULL || left == NULL || right == NULL)
        return -EINVAL;
    *left = dJointGetHingeAngleRate(r->hinge[0]);
    *right = dJointGetHingeAngleRate(r->hinge[1]);
    return 0;
}

uint64_t sim_world_collisions(const sim_world_t *w, int id)
{
    robot_t *r = get(w, id);
    return r ? r->collisions : 0;
}

double sim_world_time(const sim_world_t *w) { return w ? w->time : 0.0; }
double sim_world_dt(const sim_world_t *w) { return w ? w->cfg.dt : 0.0; }
int sim_world_robot_count(const sim_world_t *w) { return w ? w->n_robots : 0; }

const sim_robot_params_t *sim_world_robot_params(const sim_world_t *w, int id)
{
    robot_t *r = get(w, id);
    return r ? &r->p : NULL;
}

dSpaceID sim_world_walls(const sim_world_t *w) { return w ? w->walls : NULL; }

void sim_world_bounds(const sim_world_t *w, sim_vec2_t *min, sim_vec2_t *max)
{
    if (min)
        *min = w->min;
    if (max)
        *max = w->max;
}
