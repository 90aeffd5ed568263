/* summary.txt's lines of a fleet member (run_summary.h). */
#include "run_summary.h"

#include <math.h>

#include "ai/dinno_codec.h"
#include "gp/gp_pse.h"

void run_summary_fleet(FILE *f, const run_opts_t *o, const sim_image_result_t *res, uint32_t start_round,
                       const run_post_t *post)
{
    const gp_pse_stats_t *p = &res->pse; /* the whole run, start-up included */
    const double R = (double)(o->rounds - (long long)start_round); /* run by this start */
    fprintf(f, "fleet: %lld robots (this is robot %lld, fleet id %lld), %s states, radius %g m\n", o->fleet,
            o->robot, o->fleet_id, dinno_codec_name(o->encoding), o->radius);
    fprintf(f, "traffic: %.0f B sent and %.0f B received per round; %llu chunks sent, %llu received\n",
            (double)p->bytes_sent / R, (double)p->bytes_received / R, (unsigned long long)p->chunks_sent,
            (unsigned long long)p->chunks_received);
    fprintf(f, "network: %.0f B received per round in %.1f datagrams (the members' the network delivered, "
               "before the protocol keeps the nearest); %llu datagrams of senders not asked for dropped on "
               "arrival; %.0f B arrived per round in all (those and own echoes included)\n",
            (double)res->net.rx_bytes / R, (double)res->net.rx_messages / R,
            (unsigned long long)res->net.rx_unwanted, (double)res->net.rx_arrived_bytes / R);
    if (post->rounds > 0)
        fprintf(f, "posterior rounds: %u of %u (the fleet's epistemic posterior: %llu B sent, %llu B received, "
                   "not in traffic.csv)%s\n",
                post->done, post->rounds, (unsigned long long)post->sent, (unsigned long long)post->received,
                /* every robot gives the same position there, so the nearest are the lowest ids */
                o->fleet > (long long)GP_PSE_MAX_NEIGHBOURS + 1 ? "; NOT the fleet's: beyond the neighbour slots each "
                                                                   "robot mixed the lowest ids' posteriors only"
                                                                 : "");
    fprintf(f, "nearest: at most %u neighbour states per round; %llu chunks of peers beyond the radius or the "
               "nearest only placed their sender, %llu states given up for a nearer peer's; %llu peers asked "
               "where they were; %llu rounds opened without a beacon (our RoundComplete said where), %llu "
               "peers placed a round ahead by theirs\n",
            (unsigned)GP_PSE_MAX_NEIGHBOURS, (unsigned long long)p->not_nearest,
            (unsigned long long)p->evictions, (unsigned long long)p->positions_asked,
            (unsigned long long)p->openings_announced, (unsigned long long)p->placed_ahead);
    fprintf(f, "losses: %llu chunks requested again, %llu re-sent; %llu duplicates, %llu stale, %llu invalid, "
               "%llu CRC failures; %llu peer timeouts, %llu rejoins; %llu own echoes\n",
            (unsigned long long)p->chunks_requested, (unsigned long long)p->chunks_resent,
            (unsigned long long)p->duplicates, (unsigned long long)p->stale, (unsigned long long)p->invalid,
            (unsigned long long)p->crc_failures, (unsigned long long)p->timeouts,
            (unsigned long long)p->rejoins,
            (unsigned long long)(res->fleet.own_echoes + res->net.rx_own));
    fprintf(f, "faults survived: %llu chunks lost (never received), %llu recovered by a request; %llu peer "
               "states gone without, %llu rounds cut short by a later round, %llu rounds skipped to catch "
               "up; %llu peer restarts seen, %llu messages of an earlier incarnation dropped\n",
            (unsigned long long)p->chunks_lost, (unsigned long long)p->chunks_recovered,
            (unsigned long long)p->states_missed, (unsigned long long)p->rounds_cut,
            (unsigned long long)p->rounds_skipped, (unsigned long long)p->restarts,
            (unsigned long long)p->old_incarnation);
    /* The adaptive liveness rule (gp_pse.h): what it allowed, and what it did not count. */
    fprintf(f, "liveness: peer timeout %.3g s, stretched for irregular peers up to %.3g s (longest given "
               "%.3g s); %.2f s we did not run not counted against our peers\n",
            o->peer_timeout, o->peer_timeout * GP_PSE_TIMEOUT_STRETCH,
            (double)(p->timeout_longest_us > 0 ? p->timeout_longest_us : (uint64_t)llround(o->peer_timeout * 1e6)) * 1e-6,
            (double)p->stalled_us * 1e-6);
    /* Queue drops (a full queue, a buffer too small) are load; malformed datagrams are
       someone else's bytes: counted apart so that each figure means one thing. */
    fprintf(f, "waiting for peers: %.2f s wall in all (%.2f ms per round); network queue drops %llu "
               "(queue full %llu, buffer too small %llu); malformed datagrams dropped %llu; "
               "sends refused %llu; receiver queue overflows on the way %llu (copies dropped)\n",
            (double)res->fleet.wait_us * 1e-6, (double)res->fleet.wait_us * 1e-3 / R,
            (unsigned long long)(res->net.rx_dropped_full + res->net.rx_dropped_small),
            (unsigned long long)res->net.rx_dropped_full, (unsigned long long)res->net.rx_dropped_small,
            (unsigned long long)(res->net.rx_dropped_malformed + res->net.rx_dropped_invalid),
            (unsigned long long)res->pse.send_failures, (unsigned long long)res->net.tx_overflows);
    fprintf(f, "network queue: a ring of %llu B for %u messages at most; high-water mark %llu B, %u messages; "
               "%s\n",
            (unsigned long long)res->net.queue_bytes_cap, (unsigned)res->net.queue_depth,
            (unsigned long long)res->net.queue_bytes_max, (unsigned)res->net.queue_fill_max,
            res->net.rx_inline ? "received inline (no receiver thread: the socket's kernel buffer, or the writers' shared-memory rings, hold what waits)"
                               : "filled by a receiver thread");
    fprintf(f, "screen: %llu neighbour states left out (not finite, or beyond %g x ||own state||)\n",
            (unsigned long long)res->ai_status.states_excluded, (double)o->d.screen_radius);
    fprintf(f, "duals: %s rule; %llu neighbours back after %u or more missed rounds (rejoined)",
            dinno_dual_rule_name(o->d.dual_rule), (unsigned long long)res->ai_status.links_rejoined,
            o->d.rejoin_gap);
    if (dinno_codec_is_ef((dinno_codec_t)o->encoding))
        fprintf(f, "; %llu differences without their public copy left out (key round every %u)",
                (unsigned long long)res->ai_status.states_stale, o->d.key_every);
    fputc('\n', f);
    if (o->key_file != NULL)
        fprintf(f, "keyed fleet (run id %016llx): %llu datagrams without a valid tag dropped (forged or "
                   "not a member), %llu of another run dropped (replayed)\n",
                (unsigned long long)o->run_id, (unsigned long long)res->net.rx_dropped_unauth,
                (unsigned long long)res->net.rx_dropped_replay);
    if (o->net_faults != NULL && o->net_faults[0] != '\0')
        fprintf(f, "network faults injected (%s): %llu dropped, %llu partitioned, %llu duplicated, "
                   "%llu reordered, %llu delayed\n",
                o->net_faults, (unsigned long long)res->net.fault_dropped,
                (unsigned long long)res->net.fault_partitioned, (unsigned long long)res->net.fault_duplicated,
                (unsigned long long)res->net.fault_reordered, (unsigned long long)res->net.fault_delayed);
}
