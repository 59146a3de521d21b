package org.openair.internal;

import java.util.List;
import org.openair.Message;

/**
 * Lets the decoder hand a frame's chunks to a {@link Message} without the copy the public API
 * makes: the arrays come fresh from the {@link FrameReader} and nobody else holds them, so the
 * message adopts them (a received sample's payload then views the bytes read from the socket,
 * copied once out of the read buffer). {@link Message} registers the adopter when it is loaded;
 * this package is not exported, so callers of the library cannot reach it.
 *
 * <p>Threading: the adopter is set once, when {@code Message} is initialised; thread-safe.
 */
public final class Chunks {
    /** Builds a message that keeps {@code chunks} as they are. */
    public interface Adopter {
        /**
         * Build {@code builder}'s message with {@code chunks}, not copied.
         *
         * @param builder the builder
         * @param chunks the chunks, owned by nobody else
         * @return the message
         */
        Message build(Message.Builder builder, List<byte[]> chunks);
    }

    private static volatile Adopter adopter;

    private Chunks() {}

    /**
     * Called by {@link Message} when it is loaded; later calls do nothing.
     *
     * @param a the adopter
     */
    public static synchronized void register(Adopter a) {
        if (a.getClass().getNestHost() != Message.class) { // only Message's own lambda
            throw new IllegalArgumentException("not Message's adopter");
        }
        if (adopter == null) {
            adopter = a;
        }
    }

    /**
     * Build the message with {@code chunks} adopted (not copied).
     *
     * @param builder the builder (its own chunks are replaced)
     * @param chunks arrays nobody else holds or changes
     * @return the message
     */
    static Message adopt(Message.Builder builder, List<byte[]> chunks) {
        Adopter a = adopter; // set: building the builder loaded Message
        return a == null ? builder.binary(chunks).build() : a.build(builder, chunks);
    }
}
