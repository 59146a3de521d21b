package org.openair;

import java.util.Objects;

/**
 * A message the server forwarded to the module by name (OA-SESS-22): any delivery other than a
 * wakeup, PING or KEEPALIVE. The library acknowledged it before handing it over.
 *
 * <p>Threading: immutable value; safe to share between threads.
 *
 * @param message the delivered message
 * @param receivedNanos when the library read it (Unix nanoseconds)
 * @param path the connection that carried it
 */
public record Delivery(Message message, long receivedNanos, DeliveryPath path) {

    /* Require the message and path. */
    public Delivery {
        Objects.requireNonNull(message, "message");
        Objects.requireNonNull(path, "path");
    }
}
