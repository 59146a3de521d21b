// generated from spec/errors.xml by tools/gen_errors.py — do not edit
package org.openair;

/** Error conditions of the OpenAIR error table (spec/errors.xml). */
public enum ErrorCode {
    FRAME_UNKNOWN_TAG(100, Blame.REMOTE, true, "The frame header carries a tag other than Message, Receive or BinaryM, or the byte after the tag is not NUL."),
    FRAME_TOO_LARGE(101, Blame.REMOTE, true, "The announced XML length exceeds the receiver's limit."),
    FRAME_TRUNCATED(102, Blame.REMOTE, true, "The connection ended, or the read deadline passed, inside a frame."),
    BINARY_TOO_LARGE(103, Blame.REMOTE, true, "The binary chunks announced by binarysizes exceed the receiver's limit."),
    BINARY_SIZES_INVALID(104, Blame.REMOTE, true, "The binarysizes slot is not a comma-separated list of non-negative decimal integers, or disagrees with totalbinarysize."),
    XML_MALFORMED(200, Blame.REMOTE, false, "The frame's XML is not well-formed, is not UTF-8, or its root is not message."),
    XML_FORBIDDEN(201, Blame.REMOTE, false, "The XML contains a DOCTYPE, an entity declaration or an external reference."),
    XML_TOO_DEEP(202, Blame.REMOTE, false, "The XML nests elements deeper than the receiver's limit."),
    MESSAGE_INVALID(203, Blame.REMOTE, false, "A slot has an invalid value (for example a missing type, a non-numeric priority or time)."),
    TYPE_INVALID(204, Blame.REMOTE, false, "A posted type is not a valid type (empty segment, whitespace, or a '*')."),
    CONTENT_INVALID(205, Blame.REMOTE, false, "The content of a control message is not the object its type requires."),
    COMMAND_UNKNOWN(300, Blame.REMOTE, false, "The addressee does not know the command type."),
    FORWARD_FAILED(301, Blame.PEER, false, "The to slot names no whiteboard, component or bound module."),
    NAME_UNRESOLVED(302, Blame.PEER, false, "RESOLVE_REQUEST names nothing the server knows."),
    BIND_REFUSED(303, Blame.PEER, false, "The module name in BIND is not a valid name, or the requested port cannot be honoured."),
    WHITEBOARD_UNKNOWN(304, Blame.PEER, false, "A registration or retrieve names a whiteboard that does not exist."),
    AUTH_FAILED(305, Blame.REMOTE, false, "An AUTH_RESPONSE proof does not verify: no challenge is pending on the connection, the name has no secret, or the HMAC is wrong (extension auth)."),
    AUTH_REQUIRED(306, Blame.PEER, false, "In secure mode the connection has not proved the name the request acts for, or the request posts a type only the server sends (extension auth)."),
    REGISTRATION_INVALID(400, Blame.REMOTE, false, "The AIR.Subscribe content is none of the registration forms, or a trigger lacks a type."),
    PATTERN_INVALID(401, Blame.REMOTE, false, "A trigger or retrieve pattern is not a valid pattern (for example two consecutive '*')."),
    RETRIEVE_INVALID(402, Blame.REMOTE, false, "The retrieve specification is empty, unparsable, or has an invalid criterion."),
    QUEUE_OVERFLOW(500, Blame.PEER, false, "A receiving module's queue was full and messages were dropped for it."),
    DELIVERY_FAILED(501, Blame.PEER, false, "A wakeup could not be delivered after the retries the spec allows."),
    LIMIT_EXCEEDED(502, Blame.REMOTE, false, "A request exceeds a limit other than the frame limits (pipelined requests in flight, triggers per registration, retrieve results)."),
    STORE_FAILED(503, Blame.PEER, false, "The whiteboard could not store the message; it was not accepted."),
    SHUTTING_DOWN(504, Blame.PEER, true, "The server is shutting down and accepts no new work."),
    STREAM_UNKNOWN(600, Blame.PEER, false, "The stream named by a media command, or by the to of a push subscription, does not exist."),
    SAMPLE_UNKNOWN(601, Blame.PEER, false, "No sample matches the id or time asked for, or none arrived before a wait timed out."),
    SAMPLE_INVALID(602, Blame.REMOTE, false, "A sample is malformed, does not match the chunks of its request, or its payload alone exceeds the stream's byte limit."),
    LOCK_UNKNOWN(603, Blame.PEER, false, "UNLOCK_SAMPLES names a lock id that the stream never gave out, that is already released, or that another connection holds."),
    API_MISUSE(900, Blame.LOCAL, false, "The API was used in a way the protocol does not allow (for example sending in a closed state)."),
    CONNECTION_CLOSED(901, Blame.LOCAL, false, "The connection is closed; the operation cannot complete."),
    REQUEST_TIMEOUT(902, Blame.LOCAL, false, "No reply arrived within the caller's deadline."),
    REQUEST_FAILED(903, Blame.PEER, false, "The peer answered a request with a failure reply (its type and content are kept).");

    /** Who is at fault for a condition. */
    public enum Blame { REMOTE, PEER, LOCAL }

    private final int code;
    private final Blame blame;
    private final boolean closes;
    private final String description;

    ErrorCode(int code, Blame blame, boolean closes, String description) {
        this.code = code;
        this.blame = blame;
        this.closes = closes;
        this.description = description;
    }

    /** @return the stable numeric code */
    public int code() { return code; }

    /** @return who is at fault */
    public Blame blame() { return blame; }

    /** @return whether the connection is closed after this condition */
    public boolean closes() { return closes; }

    /** @return the table's one-line description */
    public String description() { return description; }

    /**
     * Look a condition up by its wire name.
     * @param name the condition name, e.g. XML_MALFORMED
     * @return the condition, or null if the name is unknown
     */
    public static ErrorCode byName(String name) {
        for (ErrorCode c : values()) {
            if (c.name().equals(name)) {
                return c;
            }
        }
        return null;
    }
}
