package org.openair;

import java.util.ArrayList;
import java.util.Arrays;
import java.util.List;
import java.util.Locale;
import java.util.Objects;
import java.util.UUID;

/**
 * One OpenAIR message (spec section 3): the slots of the envelope, its content and the binary
 * chunks that travel after its XML.
 *
 * <p>{@code content} is text when {@code contentIsXml} is false, otherwise the serialized inner XML
 * of the {@code <content>} element (zero or more elements, OA-MSG-10). A {@code null} priority
 * means the slot is absent (effective priority 2.0, OA-MSG-6). Absent text slots read as ""
 * (OA-MSG-9). {@code extras} keeps unknown slots in order (OA-MSG-5).
 *
 * <p>Threading: immutable value; safe to share between threads. Lists are copied on the way in,
 * and the binary chunks are copied both on the way in and on the way out of {@link #binary()};
 * {@link #binaryView(int)} reads a chunk without copying it.
 *
 * <p>Ids: {@link #newId()} (used by the builder) writes UUID-4 strings from one SecureRandom draw
 * per process and a counter, not one draw per message (OA-MSG-8).
 *
 * @param type the type (a message type, or a command name)
 * @param id the id, normally a UUID (OA-MSG-8)
 * @param sender the {@code from} slot
 * @param to the addressee
 * @param cc module names separated by {@code ;} (OA-CC-1)
 * @param stored the whiteboard that stored this copy, or ""
 * @param isresponse in a reply, the id of the request answered (OA-SESS-1)
 * @param inreplyto the {@code inreplyto} reference, or {@code null}
 * @param posted the postedTime, or {@code null} (a sender stamps it when sending, OA-TIME-2)
 * @param received the receivedTime a whiteboard stamped, or {@code null}
 * @param priority 0.0 (highest) to 6.999, or {@code null} when absent
 * @param timetolive the timetolive attribute, or {@code null}
 * @param noreply whether {@code noreply="yes"} is set (extension {@code noreply})
 * @param language the content's {@code language} attribute as written
 * @param content the text content, or the inner XML when {@code contentIsXml}
 * @param contentIsXml whether the content is XML ({@code language="xml"} in any case)
 * @param comment the comment slot, or ""
 * @param history the inner XML of the history slot, or ""
 * @param wbid the whiteboard sequence number, or {@code null}
 * @param netprotocol the netprotocol slot, or ""
 * @param extras the unknown slots, in order
 * @param binary the binary chunks after the XML (OA-FRAME-4)
 */
public record Message(
        String type,
        String id,
        String sender,
        String to,
        String cc,
        String stored,
        String isresponse,
        Reference inreplyto,
        AirTime posted,
        AirTime received,
        Double priority,
        Double timetolive,
        boolean noreply,
        String language,
        String content,
        boolean contentIsXml,
        String comment,
        String history,
        Long wbid,
        String netprotocol,
        List<Slot> extras,
        List<byte[]> binary) {

    /** The priority of a message without a priority slot (OA-MSG-6). */
    public static final double DEFAULT_PRIORITY = 2.0;

    /* Set only while the library's decoder builds a message from chunks it adopts. */
    private static final ThreadLocal<Boolean> ADOPTING = new ThreadLocal<>();

    static {
        org.openair.internal.Chunks.register((builder, chunks) -> {
            ADOPTING.set(Boolean.TRUE);
            try {
                return builder.binary(chunks).build();
            } finally {
                ADOPTING.remove();
            }
        });
    }

    /*
     * Normalise and check the slots.
     *
     * @throws ApiMisuseException for a priority outside 0.0-6.999 (OA-MSG-6) or a negative wbid
     */
    public Message {
        Objects.requireNonNull(type, "type");
        id = orEmpty(id);
        sender = orEmpty(sender);
        to = orEmpty(to);
        cc = orEmpty(cc);
        stored = orEmpty(stored);
        isresponse = orEmpty(isresponse);
        language = orEmpty(language);
        content = orEmpty(content);
        comment = orEmpty(comment);
        history = orEmpty(history);
        netprotocol = orEmpty(netprotocol);
        if (priority != null && !(priority >= 0.0 && priority <= 6.999)) {
            throw new ApiMisuseException("priority out of range 0.0-6.999: " + priority);
        }
        if (wbid != null && wbid < 0) {
            throw new ApiMisuseException("wbid must not be negative: " + wbid);
        }
        extras = extras == null ? List.of() : List.copyOf(extras);
        binary = ADOPTING.get() == Boolean.TRUE ? List.copyOf(binary) : copyChunks(binary);
    }

    private static String orEmpty(String s) {
        return s == null ? "" : s;
    }

    private static List<byte[]> copyChunks(List<byte[]> chunks) {
        if (chunks == null || chunks.isEmpty()) {
            return List.of();
        }
        List<byte[]> out = new ArrayList<>(chunks.size());
        for (byte[] chunk : chunks) {
            out.add(Objects.requireNonNull(chunk, "binary chunk").clone());
        }
        return List.copyOf(out);
    }

    /**
     * Return a read-only view of binary chunk {@code i}, without copying it.
     *
     * @param i the chunk's index
     * @return the view (position 0)
     */
    public java.nio.ByteBuffer binaryView(int i) {
        return java.nio.ByteBuffer.wrap(binary.get(i)).asReadOnlyBuffer();
    }

    /** @return copies of the binary chunks (the message keeps its own) */
    @Override
    public List<byte[]> binary() {
        return copyChunks(binary);
    }

    /** @return how many binary chunks the message carries */
    public int binaryCount() {
        return binary.size();
    }

    /** @return the priority used for ordering: the slot's value, or 2.0 when absent */
    public double effectivePriority() {
        return priority == null ? DEFAULT_PRIORITY : priority;
    }

    /** @return the names in {@code cc}, split on {@code ;}, trimmed, empty names skipped */
    public List<String> ccNames() {
        List<String> names = new ArrayList<>();
        for (String part : cc.split(";", -1)) {
            String name = part.strip();
            if (!name.isEmpty()) {
                names.add(name);
            }
        }
        return List.copyOf(names);
    }

    /**
     * Return the unknown slot called {@code name} (ASCII case-insensitive, OA-MSG-3).
     *
     * @param name the slot name
     * @return the slot, or {@code null}
     */
    public Slot extra(String name) {
        String folded = name.toLowerCase(Locale.ROOT);
        for (Slot slot : extras) {
            if (slot.name().toLowerCase(Locale.ROOT).equals(folded)) {
                return slot;
            }
        }
        return null;
    }

    /** @return a reference to this message, for another message's {@code inreplyto} */
    public Reference reference() {
        return new Reference(id, type, sender, to, cc, stored, posted);
    }

    /** @return a builder holding this message's slots */
    public Builder toBuilder() {
        return new Builder(this);
    }

    /**
     * Start a message of the given type, with a fresh UUID as its id.
     *
     * @param type the message type or command
     * @return the builder
     */
    public static Builder builder(String type) {
        return new Builder(type);
    }

    /** @return a fresh message id: a UUID-4 string, never repeated in this process (OA-MSG-8) */
    public static String newId() {
        return Ids.next();
    }

    /**
     * Fresh UUID-4 strings without a SecureRandom call per message: 60 random bits drawn once
     * per process, then a counter from a random start in the 62 bits after the variant (version
     * 4, variant 2, as {@code UUID.randomUUID()} writes them; OA-MSG-8).
     */
    private static final class Ids {
        private static final long MSB;
        private static final java.util.concurrent.atomic.AtomicLong COUNTER;
        private static final char[] HEX = "0123456789abcdef".toCharArray();

        static {
            UUID seed = UUID.randomUUID(); // the one SecureRandom draw
            MSB = seed.getMostSignificantBits(); // version 4 already
            COUNTER = new java.util.concurrent.atomic.AtomicLong(seed.getLeastSignificantBits());
        }

        private Ids() {}

        static String next() {
            long lsb = (COUNTER.getAndIncrement() & 0x3FFFFFFFFFFFFFFFL) | 0x8000000000000000L;
            char[] out = new char[36];
            hex(out, 0, MSB >>> 32, 8);
            out[8] = '-';
            hex(out, 9, MSB >>> 16, 4);
            out[13] = '-';
            hex(out, 14, MSB, 4);
            out[18] = '-';
            hex(out, 19, lsb >>> 48, 4);
            out[23] = '-';
            hex(out, 24, lsb, 12);
            return new String(out);
        }

        private static void hex(char[] out, int at, long value, int digits) {
            for (int i = digits - 1; i >= 0; i--) {
                out[at + i] = HEX[(int) (value & 0xF)];
                value >>>= 4;
            }
        }
    }

    @Override
    public boolean equals(Object o) {
        if (this == o) {
            return true;
        }
        if (!(o instanceof Message m)) {
            return false;
        }
        return noreply == m.noreply && contentIsXml == m.contentIsXml
                && type.equals(m.type) && id.equals(m.id) && sender.equals(m.sender)
                && to.equals(m.to) && cc.equals(m.cc) && stored.equals(m.stored)
                && isresponse.equals(m.isresponse) && Objects.equals(inreplyto, m.inreplyto)
                && Objects.equals(posted, m.posted) && Objects.equals(received, m.received)
                && Objects.equals(priority, m.priority) && Objects.equals(timetolive, m.timetolive)
                && language.equals(m.language) && content.equals(m.content)
                && comment.equals(m.comment) && history.equals(m.history)
                && Objects.equals(wbid, m.wbid) && netprotocol.equals(m.netprotocol)
                && extras.equals(m.extras) && chunksEqual(binary, m.binary);
    }

    private static boolean chunksEqual(List<byte[]> a, List<byte[]> b) {
        if (a.size() != b.size()) {
            return false;
        }
        for (int i = 0; i < a.size(); i++) {
            if (!Arrays.equals(a.get(i), b.get(i))) {
                return false;
            }
        }
        return true;
    }

    @Override
    public int hashCode() {
        int h = Objects.hash(type, id, sender, to, cc, stored, isresponse, inreplyto, posted,
                received, priority, timetolive, noreply, language, content, contentIsXml);
        h = 31 * h + Objects.hash(comment, history, wbid, netprotocol, extras);
        for (byte[] chunk : binary) {
            h = 31 * h + Arrays.hashCode(chunk);
        }
        return h;
    }

    @Override
    public String toString() {
        return "Message[type=" + type + ", id=" + id + ", from=" + sender + ", to=" + to
                + ", cc=" + cc + ", stored=" + stored + ", isresponse=" + isresponse
                + ", posted=" + posted + ", received=" + received + ", priority=" + priority
                + ", wbid=" + wbid + ", language=" + language + ", content=" + content
                + ", binary=" + binary.size() + " chunk(s)]";
    }

    /**
     * Builds a {@link Message}. Every slot starts empty except {@code id} (a fresh UUID).
     *
     * <p>Threading: a builder is not thread-safe; use it from one thread.
     */
    public static final class Builder {
        private String type;
        private String id;
        private String sender = "";
        private String to = "";
        private String cc = "";
        private String stored = "";
        private String isresponse = "";
        private Reference inreplyto;
        private AirTime posted;
        private AirTime received;
        private Double priority;
        private Double timetolive;
        private boolean noreply;
        private String language = "";
        private String content = "";
        private boolean contentIsXml;
        private String comment = "";
        private String history = "";
        private Long wbid;
        private String netprotocol = "";
        private final List<Slot> extras = new ArrayList<>();
        private final List<byte[]> binary = new ArrayList<>();

        private Builder(String type) {
            this.type = Objects.requireNonNull(type, "type");
            this.id = newId();
        }

        private Builder(Message m) {
            type = m.type;
            id = m.id;
            sender = m.sender;
            to = m.to;
            cc = m.cc;
            stored = m.stored;
            isresponse = m.isresponse;
            inreplyto = m.inreplyto;
            posted = m.posted;
            received = m.received;
            priority = m.priority;
            timetolive = m.timetolive;
            noreply = m.noreply;
            language = m.language;
            content = m.content;
            contentIsXml = m.contentIsXml;
            comment = m.comment;
            history = m.history;
            wbid = m.wbid;
            netprotocol = m.netprotocol;
            extras.addAll(m.extras);
            binary.addAll(m.binary);
        }

        /**
         * Set the type.
         *
         * @param v the type
         * @return this builder
         */
        public Builder type(String v) {
            type = v;
            return this;
        }

        /**
         * Set the id.
         *
         * @param v the id
         * @return this builder
         */
        public Builder id(String v) {
            id = v;
            return this;
        }

        /**
         * Set the {@code from} slot.
         *
         * @param v the {@code from} slot
         * @return this builder
         */
        public Builder sender(String v) {
            sender = v;
            return this;
        }

        /**
         * Set the addressee.
         *
         * @param v the addressee
         * @return this builder
         */
        public Builder to(String v) {
            to = v;
            return this;
        }

        /**
         * Set the cc slot.
         *
         * @param v names separated by {@code ;}
         * @return this builder
         */
        public Builder cc(String v) {
            cc = v;
            return this;
        }

        /**
         * Set the cc slot from module names, joined with {@code ;}.
         *
         * @param names module names, joined with {@code ;}
         * @return this builder
         */
        public Builder cc(List<String> names) {
            cc = String.join(";", names);
            return this;
        }

        /**
         * Set the stored slot.
         *
         * @param v the stored slot
         * @return this builder
         */
        public Builder stored(String v) {
            stored = v;
            return this;
        }

        /**
         * Set the id of the request answered.
         *
         * @param v the id of the request answered
         * @return this builder
         */
        public Builder isresponse(String v) {
            isresponse = v;
            return this;
        }

        /**
         * Set the inreplyto reference, or null.
         *
         * @param v the inreplyto reference, or null
         * @return this builder
         */
        public Builder inreplyto(Reference v) {
            inreplyto = v;
            return this;
        }

        /**
         * Set the postedTime, or null.
         *
         * @param v the postedTime, or null
         * @return this builder
         */
        public Builder posted(AirTime v) {
            posted = v;
            return this;
        }

        /**
         * Set the receivedTime, or null.
         *
         * @param v the receivedTime, or null
         * @return this builder
         */
        public Builder received(AirTime v) {
            received = v;
            return this;
        }

        /**
         * Set the priority, or null for absent.
         *
         * @param v the priority, or null for absent
         * @return this builder
         */
        public Builder priority(Double v) {
            priority = v;
            return this;
        }

        /**
         * Set the timetolive, or null for absent.
         *
         * @param v the timetolive, or null for absent
         * @return this builder
         */
        public Builder timetolive(Double v) {
            timetolive = v;
            return this;
        }

        /**
         * Set whether {@code noreply="yes"} is written (extension {@code noreply}).
         *
         * @param v whether noreply="yes" is set
         * @return this builder
         */
        public Builder noreply(boolean v) {
            noreply = v;
            return this;
        }

        /**
         * Set the content language attribute.
         *
         * @param v the content language attribute
         * @return this builder
         */
        public Builder language(String v) {
            language = v;
            return this;
        }

        /**
         * Set the comment slot.
         *
         * @param v the comment slot
         * @return this builder
         */
        public Builder comment(String v) {
            comment = v;
            return this;
        }

        /**
         * Set the inner XML of the history slot.
         *
         * @param v the inner XML of the history slot
         * @return this builder
         */
        public Builder history(String v) {
            history = v;
            return this;
        }

        /**
         * Set the wbid, or null.
         *
         * @param v the wbid, or null
         * @return this builder
         */
        public Builder wbid(Long v) {
            wbid = v;
            return this;
        }

        /**
         * Set the netprotocol slot.
         *
         * @param v the netprotocol slot
         * @return this builder
         */
        public Builder netprotocol(String v) {
            netprotocol = v;
            return this;
        }


        /**
         * Set text content (escaped on writing, OA-MSG-10).
         *
         * @param text the text
         * @return this builder
         */
        public Builder content(String text) {
            content = text;
            contentIsXml = false;
            if ("xml".equalsIgnoreCase(language)) {
                language = "";
            }
            return this;
        }

        /**
         * Set XML content: zero or more elements, written unescaped with {@code language="xml"}.
         *
         * @param xml the inner XML
         * @return this builder
         */
        public Builder xmlContent(String xml) {
            content = xml;
            contentIsXml = true;
            if (!"xml".equalsIgnoreCase(language)) {
                language = "xml";
            }
            return this;
        }

        /**
         * Set an unknown slot, replacing one of the same name (any case).
         *
         * @param slot the slot
         * @return this builder
         */
        public Builder extra(Slot slot) {
            extras.removeIf(s -> s.name().equalsIgnoreCase(slot.name()));
            extras.add(slot);
            return this;
        }

        /**
         * Replace every unknown slot.
         *
         * @param slots the slots, in order
         * @return this builder
         */
        public Builder extras(List<Slot> slots) {
            extras.clear();
            extras.addAll(slots);
            return this;
        }

        /**
         * Replace the binary chunks (copied when the message is built).
         *
         * @param chunks the chunks, in order
         * @return this builder
         */
        public Builder binary(List<byte[]> chunks) {
            binary.clear();
            binary.addAll(chunks);
            return this;
        }

        /** @return the message */
        public Message build() {
            return new Message(type, id, sender, to, cc, stored, isresponse, inreplyto, posted,
                    received, priority, timetolive, noreply, language, content, contentIsXml,
                    comment, history, wbid, netprotocol, extras, binary);
        }
    }
}
