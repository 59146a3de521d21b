package org.openair;

import java.time.Duration;
import java.time.Instant;
import java.util.List;
import java.util.Objects;
import java.util.Set;
import java.util.TreeSet;
import java.util.function.LongSupplier;
import javax.net.ssl.SSLSocketFactory;

/**
 * How {@link OpenAir#connect(Options)} connects a module. Build with {@link #builder(String)}.
 *
 * <p>Defaults: server {@code 127.0.0.1:10000}; BIND with a listening port chosen by the server
 * and a callback connection (the module accepts deliveries on both paths, OA-DELIV-2); every
 * extension this library implements ({@link #SUPPORTED_EXTENSIONS}), declared only when the server
 * advertises it (OA-GEN-2); 10 s request timeout (OA-SESS-27); reconnect with backoff from 50 ms
 * to 2 s; KEEPALIVE after 60 s idle (OA-KEEP-1); announce {@code Psyclone.Module.Connect.<name>}
 * as JavaOpenAIR does; the limits of spec 14.1.
 *
 * <p>Threading: immutable value; safe to share between threads. The listeners it holds are called
 * on the module's dispatcher thread (see {@link WakeupListener}).
 *
 * @param name the module's name ({@code from} of every message; bound when {@code bind})
 * @param host the server's host
 * @param port the server's main port
 * @param bind whether to bind the name (BIND or BIND_NOLISTEN); false makes a plain client
 * @param listen BIND with a listening port (true) or BIND_NOLISTEN (false, OA-SESS-5)
 * @param listenPort the port to ask for in BIND (OA-SESS-4), or 0 to let the server choose
 * @param callback whether to open the callback connection (OA-SESS-7)
 * @param extensions the extensions the module may declare (a subset of the supported ones)
 * @param requestTimeout how long to wait for each reply (OA-SESS-27)
 * @param connectTimeout how long to wait for a TCP connection
 * @param reconnect whether to reconnect (and re-register) when the primary connection is lost
 * @param reconnectDelay the first delay before reconnecting (doubled up to the maximum)
 * @param reconnectMaxDelay the longest delay between reconnection attempts
 * @param keepalive idle time before KEEPALIVE is sent (OA-KEEP-1); {@link Duration#ZERO} disables
 * @param announce whether to post {@code Psyclone.Module.Connect.<name>} after binding (spec 6.9)
 * @param inboxSize how many deliveries may wait for the dispatcher or {@code nextWakeup}
 * @param maxFrameXml the largest XML a frame may announce (OA-LIM-1)
 * @param maxFrameBinary the largest chunk total a frame may announce (OA-LIM-2)
 * @param maxXmlDepth the deepest element nesting accepted (OA-LIM-3)
 * @param wakeupListener receives wakeups, or {@code null} to read them with
 *     {@link Module#nextWakeup(Duration)}
 * @param messageListener receives forwarded messages, or {@code null} to read them with
 *     {@link Module#nextMessage(Duration)}
 * @param connectionListener hears about (re)connections and background failures, or {@code null}
 * @param clock the wall clock, in Unix nanoseconds (read as the last act before sending, OA-TIME-2)
 * @param secret the module's secret for secure mode (spec 14.3), or {@code null} (legacy)
 * @param sslSocketFactory TLS for every connection to the server (OA-AUTH-10), or {@code null}
 */
public record Options(
        String name,
        String host,
        int port,
        boolean bind,
        boolean listen,
        int listenPort,
        boolean callback,
        Set<String> extensions,
        Duration requestTimeout,
        Duration connectTimeout,
        boolean reconnect,
        Duration reconnectDelay,
        Duration reconnectMaxDelay,
        Duration keepalive,
        boolean announce,
        int inboxSize,
        long maxFrameXml,
        long maxFrameBinary,
        int maxXmlDepth,
        WakeupListener wakeupListener,
        MessageListener messageListener,
        ConnectionListener connectionListener,
        LongSupplier clock,
        Secret secret,
        SSLSocketFactory sslSocketFactory) {

    /** The extensions this library implements (OA-EXT-1), in the order it declares them. */
    public static final Set<String> SUPPORTED_EXTENSIONS =
            Set.copyOf(List.of("noreply", "pipelining", "usec"));

    /*
     * Check the options.
     *
     * @throws ApiMisuseException for an impossible combination or value
     */
    public Options {
        Objects.requireNonNull(name, "name");
        Objects.requireNonNull(host, "host");
        if (bind && name.isEmpty()) {
            throw new ApiMisuseException("a module that binds needs a name");
        }
        if (port < 1 || port > 65535) {
            throw new ApiMisuseException("port out of range 1-65535: " + port);
        }
        if (listenPort < 0 || listenPort > 65535) {
            throw new ApiMisuseException("listenPort out of range 0-65535: " + listenPort);
        }
        if (bind && !listen && !callback) {
            throw new ApiMisuseException("BIND_NOLISTEN needs the callback connection (OA-DELIV-10)");
        }
        extensions = Set.copyOf(new TreeSet<>(extensions));
        for (String ext : extensions) {
            if (!SUPPORTED_EXTENSIONS.contains(ext)) {
                throw new ApiMisuseException("extension not implemented by this library: " + ext);
            }
        }
        requirePositive(requestTimeout, "requestTimeout");
        requirePositive(connectTimeout, "connectTimeout");
        requirePositive(reconnectDelay, "reconnectDelay");
        requirePositive(reconnectMaxDelay, "reconnectMaxDelay");
        Objects.requireNonNull(keepalive, "keepalive");
        if (keepalive.isNegative()) {
            throw new ApiMisuseException("keepalive must not be negative");
        }
        if (inboxSize < 1 || maxFrameXml < 0 || maxFrameBinary < 0 || maxXmlDepth < 1) {
            throw new ApiMisuseException("inboxSize, limits and depth must be positive");
        }
        Objects.requireNonNull(clock, "clock");
    }

    private static void requirePositive(Duration d, String what) {
        Objects.requireNonNull(d, what);
        if (d.isNegative() || d.isZero()) {
            throw new ApiMisuseException(what + " must be positive");
        }
    }

    /**
     * Start options for a module called {@code name}.
     *
     * @param name the module's name
     * @return a builder holding the defaults
     */
    public static Builder builder(String name) {
        return new Builder(name);
    }

    /** @return a builder holding these options */
    public Builder toBuilder() {
        return new Builder(this);
    }

    /** @return the current time in Unix nanoseconds from the system clock */
    static long systemNanos() {
        Instant now = Instant.now();
        return now.getEpochSecond() * 1_000_000_000L + now.getNano();
    }

    /**
     * Builds {@link Options}.
     *
     * <p>Threading: a builder is not thread-safe; use it from one thread.
     */
    public static final class Builder {
        private String name;
        private String host = "127.0.0.1";
        private int port = 10000;
        private boolean bind = true;
        private boolean listen = true;
        private int listenPort;
        private boolean callback = true;
        private Set<String> extensions = SUPPORTED_EXTENSIONS;
        private Duration requestTimeout = Duration.ofSeconds(10);
        private Duration connectTimeout = Duration.ofSeconds(10);
        private boolean reconnect = true;
        private Duration reconnectDelay = Duration.ofMillis(50);
        private Duration reconnectMaxDelay = Duration.ofSeconds(2);
        private Duration keepalive = Duration.ofSeconds(60);
        private boolean announce = true;
        private int inboxSize = 10_000;
        private long maxFrameXml = 16L * 1024 * 1024;
        private long maxFrameBinary = 64L * 1024 * 1024;
        private int maxXmlDepth = 64;
        private WakeupListener wakeupListener;
        private MessageListener messageListener;
        private ConnectionListener connectionListener;
        private LongSupplier clock = Options::systemNanos;
        private Secret secret;
        private SSLSocketFactory sslSocketFactory;

        private Builder(String name) {
            this.name = name;
        }

        private Builder(Options o) {
            name = o.name;
            host = o.host;
            port = o.port;
            bind = o.bind;
            listen = o.listen;
            listenPort = o.listenPort;
            callback = o.callback;
            extensions = o.extensions;
            requestTimeout = o.requestTimeout;
            connectTimeout = o.connectTimeout;
            reconnect = o.reconnect;
            reconnectDelay = o.reconnectDelay;
            reconnectMaxDelay = o.reconnectMaxDelay;
            keepalive = o.keepalive;
            announce = o.announce;
            inboxSize = o.inboxSize;
            maxFrameXml = o.maxFrameXml;
            maxFrameBinary = o.maxFrameBinary;
            maxXmlDepth = o.maxXmlDepth;
            wakeupListener = o.wakeupListener;
            messageListener = o.messageListener;
            connectionListener = o.connectionListener;
            clock = o.clock;
            secret = o.secret;
            sslSocketFactory = o.sslSocketFactory;
        }

        /**
         * Set the module name.
         *
         * @param v the module name
         * @return this builder
         */
        public Builder name(String v) {
            name = v;
            return this;
        }

        /**
         * Set the server host.
         *
         * @param v the server host
         * @return this builder
         */
        public Builder host(String v) {
            host = v;
            return this;
        }

        /**
         * Set the server's main port.
         *
         * @param v the server's main port
         * @return this builder
         */
        public Builder port(int v) {
            port = v;
            return this;
        }

        /**
         * Set the server address.
         *
         * @param h the host
         * @param p the main port
         * @return this builder
         */
        public Builder server(String h, int p) { host = h; port = p; return this; }
        /**
         * Set whether to bind the name.
         *
         * @param v whether to bind the name
         * @return this builder
         */
        public Builder bind(boolean v) {
            bind = v;
            return this;
        }

        /**
         * Set whether to BIND with a port (true) or BIND_NOLISTEN (false).
         *
         * @param v BIND with a port (true) or BIND_NOLISTEN (false)
         * @return this builder
         */
        public Builder listen(boolean v) {
            listen = v;
            return this;
        }

        /**
         * Set the port to ask for in BIND, 0 for the server's choice.
         *
         * @param v the port to ask for, 0 for the server's choice
         * @return this builder
         */
        public Builder listenPort(int v) {
            listenPort = v;
            return this;
        }

        /**
         * Set whether to open the callback connection.
         *
         * @param v whether to open the callback connection
         * @return this builder
         */
        public Builder callback(boolean v) {
            callback = v;
            return this;
        }

        /**
         * Set the extensions the module may declare.
         *
         * @param v the extensions the module may declare
         * @return this builder
         */
        public Builder extensions(Set<String> v) {
            extensions = v;
            return this;
        }

        /**
         * Set the reply timeout.
         *
         * @param v the reply timeout
         * @return this builder
         */
        public Builder requestTimeout(Duration v) {
            requestTimeout = v;
            return this;
        }

        /**
         * Set the TCP connect timeout.
         *
         * @param v the TCP connect timeout
         * @return this builder
         */
        public Builder connectTimeout(Duration v) {
            connectTimeout = v;
            return this;
        }

        /**
         * Set whether to reconnect.
         *
         * @param v whether to reconnect
         * @return this builder
         */
        public Builder reconnect(boolean v) {
            reconnect = v;
            return this;
        }

        /**
         * Set the first reconnection delay.
         *
         * @param v the first reconnection delay
         * @return this builder
         */
        public Builder reconnectDelay(Duration v) {
            reconnectDelay = v;
            return this;
        }

        /**
         * Set the longest reconnection delay.
         *
         * @param v the longest reconnection delay
         * @return this builder
         */
        public Builder reconnectMaxDelay(Duration v) {
            reconnectMaxDelay = v;
            return this;
        }

        /**
         * Set the idle time before KEEPALIVE, ZERO to disable.
         *
         * @param v idle time before KEEPALIVE, ZERO to disable
         * @return this builder
         */
        public Builder keepalive(Duration v) {
            keepalive = v;
            return this;
        }

        /**
         * Set whether to post the Connect notice.
         *
         * @param v whether to post the Connect notice
         * @return this builder
         */
        public Builder announce(boolean v) {
            announce = v;
            return this;
        }

        /**
         * Set the delivery queue bound.
         *
         * @param v the delivery queue bound
         * @return this builder
         */
        public Builder inboxSize(int v) {
            inboxSize = v;
            return this;
        }

        /**
         * Set the XML limit per frame.
         *
         * @param v the XML limit per frame
         * @return this builder
         */
        public Builder maxFrameXml(long v) {
            maxFrameXml = v;
            return this;
        }

        /**
         * Set the binary limit per frame.
         *
         * @param v the binary limit per frame
         * @return this builder
         */
        public Builder maxFrameBinary(long v) {
            maxFrameBinary = v;
            return this;
        }

        /**
         * Set the element depth limit.
         *
         * @param v the element depth limit
         * @return this builder
         */
        public Builder maxXmlDepth(int v) {
            maxXmlDepth = v;
            return this;
        }

        /**
         * Set the wakeup listener, or null.
         *
         * @param v the wakeup listener, or null
         * @return this builder
         */
        public Builder wakeupListener(WakeupListener v) {
            wakeupListener = v;
            return this;
        }

        /**
         * Set the message listener, or null.
         *
         * @param v the message listener, or null
         * @return this builder
         */
        public Builder messageListener(MessageListener v) {
            messageListener = v;
            return this;
        }

        /**
         * Set the connection listener.
         *
         * @param v the connection listener, or null
         * @return this builder
         */
        public Builder connectionListener(ConnectionListener v) {
            connectionListener = v;
            return this;
        }
        /**
         * Set the wall clock in Unix nanoseconds.
         *
         * @param v the wall clock in Unix nanoseconds
         * @return this builder
         */
        public Builder clock(LongSupplier v) {
            clock = v;
            return this;
        }

        /**
         * Set the module's secret for secure mode (spec 14.3): the module proves its name with
         * it on every connection, and refuses a server that does not advertise {@code auth}
         * (OA-AUTH-12). Default: none (legacy mode, nothing changes on the wire).
         *
         * @param v the secret, or null for none
         * @return this builder
         */
        public Builder secret(String v) {
            secret = v == null ? null : new Secret(v);
            return this;
        }

        /**
         * Connect with TLS through this factory (OA-AUTH-10), for example
         * {@code SSLContext.getDefault().getSocketFactory()} or one built with a trust store
         * that holds the server's certificate; the host name is verified. Default: plain TCP.
         *
         * @param v the factory, or null for plain TCP
         * @return this builder
         */
        public Builder sslSocketFactory(SSLSocketFactory v) {
            sslSocketFactory = v;
            return this;
        }


        /**
         * Build the options.
         *
         * @return the options
         * @throws ApiMisuseException for an impossible combination or value
         */
        public Options build() {
            return new Options(name, host, port, bind, listen, listenPort, callback, extensions,
                    requestTimeout, connectTimeout, reconnect, reconnectDelay, reconnectMaxDelay,
                    keepalive, announce, inboxSize, maxFrameXml, maxFrameBinary, maxXmlDepth,
                    wakeupListener, messageListener, connectionListener, clock, secret,
                    sslSocketFactory);
        }
    }
}
