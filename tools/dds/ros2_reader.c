/* ros2_reader.c -- a DDS peer built only from protocol/ros2's IDL (C types by Debian's idlc) and
 * Debian's libddsc: prints what the DDS bridge publishes without ROS, and is the compatibility
 * tests' independent reader and writer (docs/dds.md).  Built as build/tools/dds/ros2_reader.
 *
 *   ros2_reader read  KIND TOPIC COUNT TIMEOUT_S   prints the matched writer (its topic, type, USER_DATA
 *                                                  and QoS), then COUNT samples
 *   ros2_reader write KIND TOPIC VALUE COUNT       writes VALUE COUNT times (KIND float64, bool, int32;
 *                                                  cell_command: VALUE is "override,cycle_mode")
 *
 * KIND: joint_states, diagnostics, float64, bool, int32; built with -DROS2_READER_CELL_MSGS and the
 * declared-type test's IDL (tests/python/dds/idl/cell_msgs/msg/Cell.idl, tests/python/dds/conftest.py)
 * also cell_status and cell_command.  One JSON object per line on stdout.
 * QoS: ROS 2's default (reliable, volatile, keep-last 10).  The domain and interface come from
 * CYCLONEDDS_URI, as for any Cyclone DDS program. */
#include <dds/dds.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "builtin_interfaces/msg/Time.h"
#ifdef ROS2_READER_CELL_MSGS
#include "cell_msgs/msg/Cell.h"
#endif
#include "diagnostic_msgs/msg/DiagnosticArray.h"
#include "sensor_msgs/msg/JointState.h"
#include "std_msgs/msg/Bool.h"
#include "std_msgs/msg/Float64.h"
#include "std_msgs/msg/Int32.h"

static const dds_topic_descriptor_t *descriptor(const char *kind) {
    if (!strcmp(kind, "joint_states")) return &sensor_msgs_msg_dds__JointState__desc;
    if (!strcmp(kind, "diagnostics")) return &diagnostic_msgs_msg_dds__DiagnosticArray__desc;
    if (!strcmp(kind, "float64")) return &std_msgs_msg_dds__Float64__desc;
    if (!strcmp(kind, "bool")) return &std_msgs_msg_dds__Bool__desc;
    if (!strcmp(kind, "int32")) return &std_msgs_msg_dds__Int32__desc;
#ifdef ROS2_READER_CELL_MSGS
    if (!strcmp(kind, "cell_status")) return &cell_msgs_msg_dds__CellStatus__desc;
    if (!strcmp(kind, "cell_command")) return &cell_msgs_msg_dds__CellCommand__desc;
#endif
    return NULL;
}

static void json_string(const char *s) {
    putchar('"');
    for (; s && *s; ++s) {
        if (*s == '"' || *s == '\\') putchar('\\');
        if ((unsigned char)*s < 0x20)
            printf("\\u%04x", *s);
        else
            putchar(*s);
    }
    putchar('"');
}

static dds_qos_t *ros2_default_qos(void) {
    dds_qos_t *qos = dds_create_qos();
    dds_qset_reliability(qos, DDS_RELIABILITY_RELIABLE, DDS_MSECS(100));
    dds_qset_durability(qos, DDS_DURABILITY_VOLATILE);
    dds_qset_history(qos, DDS_HISTORY_KEEP_LAST, 10);
    return qos;
}

static void print_match(dds_entity_t reader) {
    dds_instance_handle_t handles[8];
    dds_return_t n = dds_get_matched_publications(reader, handles, 8);
    for (dds_return_t i = 0; i < n; ++i) {
        dds_builtintopic_endpoint_t *ep = dds_get_matched_publication_data(reader, handles[i]);
        if (!ep) continue;
        dds_reliability_kind_t rel = DDS_RELIABILITY_BEST_EFFORT;
        dds_durability_kind_t dur = DDS_DURABILITY_VOLATILE;
        dds_duration_t blocking = 0;
        dds_qget_reliability(ep->qos, &rel, &blocking);
        dds_qget_durability(ep->qos, &dur);
        printf("{\"match\": {\"topic\": ");
        json_string(ep->topic_name);
        printf(", \"type\": ");
        json_string(ep->type_name);
        void *user_data = NULL; /* the writer's USER_DATA (the bridge names its variables there) */
        size_t user_size = 0;
        printf(", \"user_data\": ");
        json_string(dds_qget_userdata(ep->qos, &user_data, &user_size) && user_data ? (const char *)user_data : "");
        dds_free(user_data);
        printf(", \"reliability\": \"%s\", \"durability\": \"%s\"}}\n",
               rel == DDS_RELIABILITY_RELIABLE ? "reliable" : "best_effort",
               dur == DDS_DURABILITY_VOLATILE          ? "volatile"
               : dur == DDS_DURABILITY_TRANSIENT_LOCAL ? "transient_local"
                                                       : "other");
        dds_builtintopic_free_endpoint(ep);
    }
    fflush(stdout);
}

static void print_sample(const char *kind, const void *s) {
    if (!strcmp(kind, "joint_states")) {
        const sensor_msgs_msg_dds__JointState_ *m = s;
        printf("{\"sec\": %d, \"nanosec\": %u, \"frame_id\": ", m->header.stamp.sec, m->header.stamp.nanosec);
        json_string(m->header.frame_id);
        printf(", \"name\": [");
        for (uint32_t i = 0; i < m->name._length; ++i) {
            if (i) printf(", ");
            json_string(m->name._buffer[i]);
        }
        printf("], \"position\": [");
        for (uint32_t i = 0; i < m->position._length; ++i) printf("%s%.17g", i ? ", " : "", m->position._buffer[i]);
        printf("], \"velocity\": %u, \"effort\": %u}\n", m->velocity._length, m->effort._length);
    } else if (!strcmp(kind, "diagnostics")) {
        const diagnostic_msgs_msg_dds__DiagnosticArray_ *m = s;
        printf("{\"sec\": %d, \"status\": [", m->header.stamp.sec);
        for (uint32_t i = 0; i < m->status._length; ++i) {
            const diagnostic_msgs_msg_dds__DiagnosticStatus_ *st = &m->status._buffer[i];
            printf("%s{\"level\": %u, \"name\": ", i ? ", " : "", st->level);
            json_string(st->name);
            printf(", \"message\": ");
            json_string(st->message);
            printf(", \"hardware_id\": ");
            json_string(st->hardware_id);
            printf(", \"values\": {");
            for (uint32_t k = 0; k < st->values._length; ++k) {
                printf("%s", k ? ", " : "");
                json_string(st->values._buffer[k].key);
                printf(": ");
                json_string(st->values._buffer[k].value);
            }
            printf("}}");
        }
        printf("]}\n");
#ifdef ROS2_READER_CELL_MSGS
    } else if (!strcmp(kind, "cell_status")) {
        const cell_msgs_msg_dds__CellStatus_ *m = s;
        printf("{\"sec\": %d, \"nanosec\": %u, \"frame_id\": ", m->header.stamp.sec, m->header.stamp.nanosec);
        json_string(m->header.frame_id);
        printf(", \"cycles\": %u, \"running\": %d, \"joints\": [", m->cycles, m->running);
        for (int i = 0; i < 6; ++i) printf("%s%.17g", i ? ", " : "", m->joints[i]);
        printf("], \"first\": [");
        for (uint32_t i = 0; i < m->first._length; ++i) printf("%s%.17g", i ? ", " : "", m->first._buffer[i]);
        printf("], \"note\": ");
        json_string(m->note);
        printf("}\n");
#endif
    } else if (!strcmp(kind, "float64")) {
        printf("{\"data\": %.17g}\n", ((const std_msgs_msg_dds__Float64_ *)s)->data);
    } else if (!strcmp(kind, "bool")) {
        printf("{\"data\": %s}\n", ((const std_msgs_msg_dds__Bool_ *)s)->data ? "true" : "false");
    } else {
        printf("{\"data\": %d}\n", ((const std_msgs_msg_dds__Int32_ *)s)->data);
    }
    fflush(stdout);
}

int main(int argc, char **argv) {
    if (argc != 6 || !descriptor(argv[2]) || (strcmp(argv[1], "read") && strcmp(argv[1], "write"))) {
        fprintf(stderr, "usage: %s read KIND TOPIC COUNT TIMEOUT_S | write KIND TOPIC VALUE COUNT\n", argv[0]);
        return 2;
    }
    const char *kind = argv[2];
    dds_entity_t participant = dds_create_participant(DDS_DOMAIN_DEFAULT, NULL, NULL);
    if (participant < 0) {
        fprintf(stderr, "participant: %s\n", dds_strretcode(-participant));
        return 1;
    }
    dds_entity_t topic = dds_create_topic(participant, descriptor(kind), argv[3], NULL, NULL);
    if (topic < 0) {
        fprintf(stderr, "topic: %s\n", dds_strretcode(-topic));
        return 1;
    }
    dds_qos_t *qos = ros2_default_qos();
    int rc = 0;
    if (!strcmp(argv[1], "read")) {
        long want = atol(argv[4]);
        dds_time_t until = dds_time() + DDS_SECS(atol(argv[5]));
        dds_entity_t reader = dds_create_reader(participant, topic, qos, NULL);
        void *samples[16] = {0};
        dds_sample_info_t infos[16];
        long got = 0;
        int matched = 0;
        while (got < want && dds_time() < until) {
            if (!matched) {
                dds_subscription_matched_status_t st;
                if (dds_get_subscription_matched_status(reader, &st) == 0 && st.current_count > 0)
                    print_match(reader), matched = 1;
            }
            dds_return_t n = dds_take(reader, samples, infos, 16, 16);
            for (dds_return_t i = 0; i < n && got < want; ++i)
                if (infos[i].valid_data) print_sample(kind, samples[i]), ++got;
            if (n > 0)
                dds_return_loan(reader, samples, n);
            else
                dds_sleepfor(DDS_MSECS(1));
        }
        rc = got < want ? 3 : 0;
    } else {
        dds_entity_t writer = dds_create_writer(participant, topic, qos, NULL);
        dds_time_t until = dds_time() + DDS_SECS(10);
        dds_publication_matched_status_t st = {0};
        while (dds_time() < until && (dds_get_publication_matched_status(writer, &st), st.current_count == 0))
            dds_sleepfor(DDS_MSECS(10));
        dds_sleepfor(DDS_MSECS(200));
        long count = atol(argv[5]);
        double value = atof(argv[4]);
        for (long i = 0; i < count; ++i) {
            std_msgs_msg_dds__Float64_ f = {value};
            std_msgs_msg_dds__Bool_ b = {value != 0};
            std_msgs_msg_dds__Int32_ n = {(int32_t)value};
            const void *sample = !strcmp(kind, "float64") ? (const void *)&f
                                 : !strcmp(kind, "bool")  ? (const void *)&b
                                                          : (const void *)&n;
#ifdef ROS2_READER_CELL_MSGS
            const char *comma = strchr(argv[4], ',');
            cell_msgs_msg_dds__CellCommand_ c = {.header = {.frame_id = "peer"},
                                                 .override = value,
                                                 .cycle_mode = (int16_t)(comma ? atoi(comma + 1) : 0)};
            if (!strcmp(kind, "cell_command")) sample = &c;
#endif
            dds_write(writer, sample);
        }
        dds_sleepfor(DDS_MSECS(300)); /* reliable: let the last samples arrive */
        printf("{\"written\": %ld, \"matched\": %d}\n", count, st.current_count);
    }
    dds_delete_qos(qos);
    dds_delete(participant);
    return rc;
}
