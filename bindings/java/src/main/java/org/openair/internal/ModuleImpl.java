package org.openair.internal;

import java.lang.System.Logger.Level;
import java.net.Socket;
import java.time.Duration;
import java.util.ArrayList;
import java.util.HashMap;
import java.util.Map;
import java.util.List;
import java.util.Optional;
import java.util.Set;
import java.util.TreeSet;
import java.util.concurrent.BlockingQueue;
import java.util.concurrent.CompletableFuture;
import java.util.concurrent.CompletionException;
import java.util.concurrent.Executors;
import java.util.concurrent.LinkedBlockingQueue;
import java.util.concurrent.ScheduledExecutorService;
import java.util.concurrent.TimeUnit;
import java.util.concurrent.TimeoutException;
import java.util.concurrent.atomic.AtomicLong;
import org.openair.ApiMisuseException;
import org.openair.Capabilities;
import org.openair.ConnectionClosedException;
import org.openair.ConnectionListener;
import org.openair.Delivery;
import org.openair.DeliveryPath;
import org.openair.ErrorCode;
import org.openair.AlarmSubscription;
import org.openair.Message;
import org.openair.ReceivedSample;
import org.openair.StreamHandle;
import org.openair.StreamInfo;
import org.openair.Module;
import org.openair.OpenAirException;
import org.openair.Options;
import org.openair.Registration;
import org.openair.RequestFailedException;
import org.openair.RequestTimeoutException;
import org.openair.RetrieveSpec;
import org.openair.Slot;
import org.openair.Wakeup;

/**
 * The module: one primary connection for requests ({@link Link}), a receiving side for deliveries
 * ({@link Listener}), one dispatcher thread for the listeners and one maintenance thread for
 * reconnection and KEEPALIVE. Connecting follows JavaOpenAIR: GET_CAPABILITIES (legacy on
 * anything but CAPABILITIES, OA-CAP-2), BIND or BIND_NOLISTEN, listen on the port of BIND_ACCEPT,
 * open the callback connection, post {@code Psyclone.Module.Connect.<name>}. When the primary
 * connection is lost the module reconnects with backoff, binds again, re-sends its registration
 * and posts {@code Psyclone.Module.Reconnect.<name>}.
 *
 * <p>Threading: thread-safe; see {@link Module}.
 */
public final class ModuleImpl implements Module {
    private static final System.Logger LOG = System.getLogger("org.openair");
    private static final String CNS = "CNS";
    private static final String AIRCENTRAL = "AIRCentral";
    private static final int DEFAULT_MAX_IN_FLIGHT = 256; // OA-LIM-5
    private static final Wakeup CLOSED_WAKEUP = new Wakeup(
            Message.builder("closed").build(), null, List.of(), "", "", 0, DeliveryPath.CALLBACK);
    private static final ReceivedSample CLOSED_SAMPLE = new ReceivedSample("",
            org.openair.DataSample.of(new byte[0]), 0, 0);
    private static final Delivery CLOSED_DELIVERY =
            new Delivery(Message.builder("closed").build(), 0, DeliveryPath.CALLBACK);

    private final Options o;
    private final String name;
    private final Object lock = new Object();
    private final Listener listener;
    private final Dispatcher dispatcher;
    private final ScheduledExecutorService maintenance;
    private final BlockingQueue<Wakeup> wakeups = new LinkedBlockingQueue<>();
    private final BlockingQueue<Delivery> messages;
    private Link link; // guarded by lock; set once the connection is set up
    private int generation; // guarded by lock
    private boolean closed; // guarded by lock
    private boolean lost; // guarded by lock: lost for good (no reconnection)
    private volatile Capabilities capabilities;
    private volatile boolean legacy;
    private volatile Set<String> extensions = Set.of();
    private volatile int boundPort = -1;
    private volatile Registration registration;
    private final AtomicLong undecodable = new AtomicLong(); // OA-MSG-20
    private final AtomicLong dropped = new AtomicLong();
    private volatile int window = 1;
    private final BlockingQueue<ReceivedSample> samples;
    private final Map<String, StreamHandleImpl> streams = new HashMap<>(); // guarded by lock
    private final List<AlarmSubscriptionImpl> alarmSubs = new ArrayList<>(); // guarded by lock

    private ModuleImpl(Options o) {
        this.o = o;
        this.name = o.name();
        this.messages = new LinkedBlockingQueue<>(o.inboxSize());
        this.samples = new LinkedBlockingQueue<>(o.inboxSize());
        this.dispatcher = new Dispatcher(name, o.inboxSize(), this::reportListenerFailure);
        this.listener = new Listener(name, this::handle, this::newSession, o.clock(),
                this::reportError, this::deliveryDropped);
        this.maintenance = Executors.newSingleThreadScheduledExecutor(r -> {
            Thread t = new Thread(r, "openair-" + name + "-maintenance");
            t.setDaemon(true);
            return t;
        });
    }

    /**
     * Connect and set a module up (see {@link org.openair.OpenAir#connect}).
     *
     * @param options how to connect
     * @return the module
     */
    public static Module connect(Options options) {
        ModuleImpl m = new ModuleImpl(options);
        try {
            m.establish(true);
        } catch (RuntimeException e) {
            m.close();
            throw e;
        }
        if (!options.keepalive().isZero()) {
            long every = Math.max(50, options.keepalive().toMillis() / 4);
            m.maintenance.scheduleWithFixedDelay(m::keepalive, every, every, TimeUnit.MILLISECONDS);
        }
        return m;
    }

    private Session newSession(Session.Role role) {
        Session s = new Session(role, o.clock(), name, o.maxFrameXml(), o.maxFrameBinary(),
                o.maxXmlDepth());
        s.extensions(extensions); // OA-SESS-19: a declaration applies to every delivery
        return s;
    }

    // ------------------------------------------------------------------------- lifecycle

    private void establish(boolean first) {
        int attempt;
        synchronized (lock) {
            attempt = generation + 1;
        }
        Link l = Link.open(Auth.connect(o, o.host(), o.port()),
                newSession(Session.Role.REQUESTER), "openair-" + name + "-primary-" + attempt,
                this::primaryLost);
        try {
            negotiate(l);
            Auth.checkSecure(o, capabilities); // OA-AUTH-12
            Auth.prove(o, l); // spec 14.3: before anything acts for the name
            if (o.bind()) {
                bindAndReceive(l);
                Registration reg = registration;
                if (reg != null) {
                    sendRegistration(l, reg);
                }
                if (o.announce()) {
                    announce(l, "Psyclone.Module." + (first ? "Connect." : "Reconnect.") + name);
                }
            }
        } catch (RuntimeException e) {
            l.close();
            throw e;
        }
        int gen;
        synchronized (lock) {
            if (closed) {
                l.close();
                throw new ConnectionClosedException("the module was closed while connecting");
            }
            link = l;
            gen = ++generation;
            lock.notifyAll();
        }
        if (l.isClosed()) {
            primaryLost(l, null); // it died before it was installed
        }
        ConnectionListener cl = o.connectionListener();
        if (cl != null) {
            dispatcher.offer(() -> cl.onConnected(gen));
        }
    }

    /** Ask GET_CAPABILITIES; anything but CAPABILITIES means a legacy server (OA-CAP-2). */
    private void negotiate(Link l) {
        Message ask = Message.builder("GET_CAPABILITIES").sender(name).to(CNS).build();
        Message reply = l.request(ask, o.requestTimeout())[1];
        Capabilities caps = null;
        if (reply.type().equals("CAPABILITIES")) {
            try {
                caps = ContentObjects.parseCapabilities(reply.content());
            } catch (OpenAirException e) {
                LOG.log(Level.WARNING, "unreadable CAPABILITIES, treating the server as legacy: "
                        + e.getMessage());
            }
        }
        capabilities = caps;
        legacy = caps == null;
        Set<String> using = new TreeSet<>(o.extensions());
        using.retainAll(caps == null ? Set.of() : caps.extensions()); // OA-GEN-2
        extensions = java.util.Collections.unmodifiableSet(using); // sorted, for display
        long limit = caps == null ? DEFAULT_MAX_IN_FLIGHT
                : caps.limit("max-in-flight").orElse(DEFAULT_MAX_IN_FLIGHT);
        int window = using.contains("pipelining") ? (int) Math.max(1, Math.min(limit, 4096)) : 1;
        this.window = window;
        l.configure(window, extensions); // OA-SESS-17, OA-SESS-18
    }

    /** Add the {@code extensions} slot, only towards a server that is not legacy (OA-SESS-19). */
    private Message declare(Message.Builder b) {
        if (!legacy) { // OA-GEN-2: a legacy server never sees an extension's wire form
            b.extra(Slot.text("extensions", String.join(" ", new TreeSet<>(extensions))));
        }
        return b.build();
    }

    private void bindAndReceive(Link l) {
        Message.Builder b = Message.builder(o.listen() ? "BIND" : "BIND_NOLISTEN")
                .sender(name).to(CNS);
        if (o.listen() && o.listenPort() > 0) { // OA-SESS-4
            b.xmlContent(ContentObjects.encodePortRequest(o.listenPort()));
        }
        Message[] r = l.request(declare(b), o.requestTimeout());
        expect(r, "BIND_ACCEPT");
        int port;
        try {
            port = Integer.parseInt(Dom.strip(r[1].content())); // OA-SESS-3, OA-SESS-5
        } catch (NumberFormatException e) {
            throw new RequestFailedException(r[0], r[1]);
        }
        boundPort = port;
        if (o.listen() && port > 0) {
            listener.listen(l.localAddress(), port); // OA-DELIV-10
        }
        if (o.callback()) {
            Message note = declare(Message.builder("RECEIVE_NAME_NOTIFICATION").sender(name));
            Socket socket = Auth.connect(o, o.host(), o.port());
            Auth.prove(o, socket, newSession(Session.Role.REQUESTER)); // OA-AUTH-6
            listener.openCallback(socket, note); // OA-SESS-7
        }
    }

    private void announce(Link l, String type) {
        if (!Types.isValidType(type)) {
            return; // a module name that cannot form a type: nothing to announce
        }
        Message notice = Message.builder(type).sender(name).to(AIRCENTRAL).build();
        expect(l.request(notice, o.requestTimeout()), "RECEIVE_ACCEPT");
    }

    private void primaryLost(Link l, OpenAirException cause) {
        synchronized (lock) {
            if (l != link || closed) {
                return;
            }
            link = null;
            lost = !o.reconnect();
            lock.notifyAll();
        }
        LOG.log(Level.INFO, name + ": primary connection lost (" + (cause == null
                ? "closed by the server" : cause.getMessage()) + ")");
        ConnectionListener cl = o.connectionListener();
        if (cl != null) {
            dispatcher.offer(() -> cl.onDisconnected(cause));
        }
        if (o.reconnect()) {
            maintenance.execute(this::reconnectLoop);
        }
    }

    private void reconnectLoop() {
        long delay = o.reconnectDelay().toMillis();
        while (!isClosed()) {
            try {
                Thread.sleep(delay);
                establish(false);
                return;
            } catch (InterruptedException e) {
                return; // closing
            } catch (OpenAirException e) {
                LOG.log(Level.INFO, name + ": reconnect failed (" + e.getMessage() + ")");
                delay = Math.min(delay * 2, o.reconnectMaxDelay().toMillis());
            }
        }
    }

    /** Send KEEPALIVE after the idle time (OA-KEEP-1); an unanswered one never closes (OA-KEEP-3). */
    private void keepalive() {
        Link l;
        synchronized (lock) {
            l = link;
        }
        if (l == null || System.nanoTime() - l.lastTraffic() < o.keepalive().toNanos()) {
            return;
        }
        try {
            l.submit(Message.builder("KEEPALIVE").id(Message.newId()).build(), o.requestTimeout());
        } catch (OpenAirException e) {
            LOG.log(Level.DEBUG, "KEEPALIVE not sent: " + e.getMessage());
        }
    }

    private boolean isClosed() {
        synchronized (lock) {
            return closed;
        }
    }

    @Override
    public void close() {
        Link l;
        synchronized (lock) {
            if (closed) {
                return;
            }
            closed = true;
            l = link;
            link = null;
            lock.notifyAll();
        }
        maintenance.shutdownNow();
        List<StreamHandleImpl> handles;
        List<AlarmSubscriptionImpl> alarmsOpen;
        synchronized (lock) {
            handles = new ArrayList<>(streams.values());
            alarmsOpen = new ArrayList<>(alarmSubs);
            streams.clear();
            alarmSubs.clear();
        }
        for (StreamHandleImpl h : handles) {
            h.close();
        }
        for (AlarmSubscriptionImpl a : alarmsOpen) {
            a.close();
        }
        if (l != null) {
            l.close();
        }
        listener.close();
        wakeups.offer(CLOSED_WAKEUP); // wakes a waiting consumer
        messages.poll();
        messages.offer(CLOSED_DELIVERY);
        samples.poll();
        samples.offer(CLOSED_SAMPLE);
        dispatcher.close();
    }

    // ------------------------------------------------------------------------- deliveries

    /** Handle one delivery on its connection's thread; the connection answers it (OA-DELIV-4). */
    private String handle(Message msg, long receivedNanos, DeliveryPath path) {
        if (msg.type().equals("PING") || msg.type().equals("KEEPALIVE")) {
            return null; // PING_SUCCESS, KEEPALIVESUCCESS (OA-SESS-11)
        }
        try {
            if (msg.type().equals(ContentObjects.WAKEUP_TYPE)) {
                Wakeup w = ContentObjects.parseWakeup(msg, receivedNanos, path); // else RECEIVE_ERROR
                if (o.wakeupListener() != null) {
                    dispatcher.submit(() -> o.wakeupListener().onWakeup(w));
                } else {
                    wakeups.put(w); // a full inbox holds the acknowledgement back
                }
                return null;
            }
            if (msg.type().equals("DATASAMPLE")) { // OA-STREAM-14: a subscribed stream
                samples.put(StreamWire.receivedOf(msg, receivedNanos)); // else RECEIVE_ERROR
                return null;
            }
            Delivery d = new Delivery(msg, receivedNanos, path);
            if (o.messageListener() != null) {
                dispatcher.submit(() -> o.messageListener().onMessage(d));
            } else if (!messages.offer(d)) { // nobody may be reading these: keep the newest
                messages.poll();
                dropped.incrementAndGet();
                messages.offer(d);
            }
            return null;
        } catch (InterruptedException e) {
            Thread.currentThread().interrupt();
            throw new ConnectionClosedException("interrupted while handing a delivery over");
        }
    }

    /**
     * Count, log and report a delivery that cannot be read: never lose one silently (OA-MSG-20).
     * {@code error} goes to the connection listener unless it was reported already (null).
     */
    private void deliveryDropped(String reason, OpenAirException error) {
        undecodable.incrementAndGet();
        dropped.incrementAndGet();
        LOG.log(Level.WARNING, name + ": delivery dropped: " + reason);
        ConnectionListener cl = o.connectionListener();
        if (error != null && cl != null) {
            dispatcher.offer(() -> cl.onError(error));
        }
    }

    private void reportError(Throwable error) {
        LOG.log(Level.DEBUG, name + ": delivery connection ended: " + error);
        ConnectionListener cl = o.connectionListener();
        if (cl != null) {
            dispatcher.offer(() -> cl.onError(error));
        }
    }

    private void reportListenerFailure(Throwable error) {
        LOG.log(Level.WARNING, name + ": a listener failed: " + error);
        ConnectionListener cl = o.connectionListener();
        if (cl != null) {
            try {
                cl.onError(error);
            } catch (RuntimeException e) {
                LOG.log(Level.WARNING, name + ": the connection listener failed: " + e);
            }
        }
    }

    @Override
    public Optional<Wakeup> nextWakeup(Duration timeout) {
        if (o.wakeupListener() != null) {
            throw new ApiMisuseException("wakeups go to the wakeup listener");
        }
        Wakeup w = poll(wakeups, timeout);
        if (w == CLOSED_WAKEUP) {
            wakeups.offer(CLOSED_WAKEUP); // for the next waiter
            return Optional.empty();
        }
        return Optional.ofNullable(w);
    }

    @Override
    public Optional<Delivery> nextMessage(Duration timeout) {
        if (o.messageListener() != null) {
            throw new ApiMisuseException("messages go to the message listener");
        }
        Delivery d = poll(messages, timeout);
        if (d == CLOSED_DELIVERY) {
            messages.offer(CLOSED_DELIVERY);
            return Optional.empty();
        }
        return Optional.ofNullable(d);
    }

    private static <T> T poll(BlockingQueue<T> queue, Duration timeout) {
        try {
            return queue.poll(timeout.toNanos(), TimeUnit.NANOSECONDS);
        } catch (InterruptedException e) {
            Thread.currentThread().interrupt();
            return null;
        }
    }

    // --------------------------------------------------------------------------- requests

    private Link waitLink() {
        long deadline = System.nanoTime() + o.requestTimeout().toNanos();
        synchronized (lock) {
            while (true) {
                if (closed) {
                    throw new ConnectionClosedException("the module is closed");
                }
                if (lost) {
                    throw new ConnectionClosedException("the connection to the server was lost");
                }
                if (link != null) {
                    return link;
                }
                long left = deadline - System.nanoTime();
                if (left <= 0) {
                    throw new RequestTimeoutException("not connected within "
                            + o.requestTimeout().toMillis() + " ms");
                }
                try {
                    TimeUnit.NANOSECONDS.timedWait(lock, left);
                } catch (InterruptedException e) {
                    Thread.currentThread().interrupt();
                    throw new RequestTimeoutException("interrupted while waiting to reconnect");
                }
            }
        }
    }

    private static void expect(Message[] sentAndReply, String... types) {
        for (String t : types) {
            if (sentAndReply[1].type().equals(t)) {
                return;
            }
        }
        throw new RequestFailedException(sentAndReply[0], sentAndReply[1]);
    }

    private Message prepare(Message msg) {
        Types.validateType(msg.type(), ErrorCode.API_MISUSE); // OA-TYPE-1, refused locally
        Message.Builder b = msg.toBuilder().noreply(false);
        if (msg.sender().isEmpty()) {
            b.sender(name);
        }
        return b.build();
    }

    @Override
    public Message post(String to, String type, String content) {
        return post(Message.builder(type).sender(name).to(to).content(content).build());
    }

    @Override
    public Message post(Message message) {
        Message[] r = waitLink().request(prepare(message), o.requestTimeout());
        expect(r, "RECEIVE_ACCEPT"); // OA-WB-3
        return r[0];
    }

    @Override
    public CompletableFuture<Message> postAsync(Message message) {
        Link l = waitLink();
        Link.Sent sent = l.submit(prepare(message), o.requestTimeout());
        // handleAsync: the caller's continuations never run on the connection's reader thread.
        return sent.reply().orTimeout(o.requestTimeout().toNanos(), TimeUnit.NANOSECONDS)
                .handleAsync((reply, error) -> {
                    if (error instanceof TimeoutException) {
                        l.abort(); // OA-SESS-27
                        throw new RequestTimeoutException(message.type() + ": no reply in time");
                    }
                    if (error != null) {
                        throw error instanceof OpenAirException oa ? oa
                                : new CompletionException(error);
                    }
                    expect(new Message[] {sent.message(), reply}, "RECEIVE_ACCEPT");
                    return sent.message();
                });
    }

    @Override
    public List<Message> postAll(List<Message> list) {
        Link l = waitLink();
        List<Link.Sent> pending = new ArrayList<>();
        for (Message m : list) { // pipelined up to the window (OA-SESS-17)
            pending.add(l.submit(prepare(m), o.requestTimeout()));
        }
        List<Message> sent = new ArrayList<>();
        OpenAirException failure = null;
        for (Link.Sent s : pending) {
            try {
                expect(new Message[] {s.message(), l.await(s, o.requestTimeout())},
                        "RECEIVE_ACCEPT");
            } catch (OpenAirException e) {
                failure = failure == null ? e : failure;
            }
            sent.add(s.message());
        }
        if (failure != null) {
            throw failure;
        }
        return sent;
    }

    @Override
    public Message postNoReply(Message message) {
        Link l = waitLink();
        Message prepared = prepare(message);
        if (extensions.contains("noreply")) { // OA-MSG-15
            return l.sendNoReply(prepared.toBuilder().noreply(true).build());
        }
        Link.Sent s = l.submit(prepared, o.requestTimeout()); // OA-GEN-2: an ordinary post
        s.reply().whenComplete((reply, error) -> {
            if (error != null || !reply.type().equals("RECEIVE_ACCEPT")) {
                LOG.log(Level.WARNING, "unacknowledged post failed: "
                        + (error != null ? error : reply.type()));
            }
        });
        return s.message();
    }

    @Override
    public void subscribe(Registration reg) {
        String content = ContentObjects.encodeRegistration(name, reg); // validates (OA-MATCH-7)
        sendRegistration(waitLink(), reg, content);
        registration = reg;
    }

    private void sendRegistration(Link l, Registration reg) {
        sendRegistration(l, reg, ContentObjects.encodeRegistration(name, reg));
    }

    private void sendRegistration(Link l, Registration reg, String content) {
        Message msg = Message.builder("AIR.Subscribe").sender(name).to(AIRCENTRAL)
                .xmlContent(content).build();
        expect(l.request(msg, o.requestTimeout()), "RECEIVE_ACCEPT"); // OA-REG-7
    }

    @Override
    public List<Message> retrieve(RetrieveSpec spec) {
        return retrieve(List.of(spec), AIRCENTRAL);
    }

    @Override
    public List<Message> retrieve(List<RetrieveSpec> specs, String to) {
        String kind = specs.size() == 1 ? "AIR.Retrieve" : "AIR.Retrieves"; // OA-RET-1
        String content = specs.size() == 1 ? ContentObjects.encodeRetrieve(specs.get(0))
                : ContentObjects.encodeRetrieves(specs);
        Message msg = Message.builder(kind).sender(name).to(to).xmlContent(content).build();
        Message[] r = waitLink().request(msg, o.requestTimeout());
        expect(r, kind + ".Success"); // OA-RET-7
        return ContentObjects.parseMessageCollection(r[1]); // with attachments (OA-RET-19)
    }

    @Override
    public Message request(Message request) {
        return waitLink().request(request, o.requestTimeout())[1];
    }

    @Override
    public Duration ping() {
        long start = System.nanoTime();
        Message[] r = waitLink().request(
                Message.builder("PING").sender(name).to(CNS).build(), o.requestTimeout());
        Duration rtt = Duration.ofNanos(System.nanoTime() - start);
        expect(r, "PING_SUCCESS"); // OA-SESS-10
        return rtt;
    }

    // ---------------------------------------------------------------------------- streams

    /** @return the options the module was made with */
    Options options() {
        return o;
    }

    /**
     * A requester session for a push connection, with {@code accepted} as its extensions.
     *
     * @param accepted the extensions this connection declares
     * @return the session
     */
    Session newStreamSession(Set<String> accepted) {
        Session s = newSession(Session.Role.REQUESTER);
        s.extensions(accepted);
        return s;
    }

    /**
     * Open a requester connection for a stream handle, set up like the primary one (window,
     * extensions in use).
     *
     * @param what names the reader thread
     * @return the link
     */
    Link openStreamLink(String what) {
        if (isClosed()) {
            throw new ConnectionClosedException("the module is closed");
        }
        Link l = Link.open(Auth.connect(o, o.host(), o.port()),
                newSession(Session.Role.REQUESTER), "openair-" + name + "-" + what,
                (link, cause) -> LOG.log(Level.DEBUG, name + ": stream connection ended"
                        + (cause == null ? "" : ": " + cause.getMessage())));
        try {
            Auth.prove(o, l); // spec 14.3
        } catch (RuntimeException e) {
            l.close();
            throw e;
        }
        l.configure(window, extensions);
        return l;
    }

    @Override
    public StreamHandle stream(String target) {
        synchronized (lock) {
            if (closed) {
                throw new ConnectionClosedException("the module is closed");
            }
            return streams.computeIfAbsent(target, t -> new StreamHandleImpl(this, t));
        }
    }

    @Override
    public List<StreamInfo> listStreams() {
        Message msg = Message.builder("GET_STREAMS").sender(name).to(CNS).build();
        Message[] r = waitLink().request(msg, o.requestTimeout());
        expect(r, "STREAMS"); // OA-STREAM-16
        return StreamWire.streamsOf(r[1]);
    }

    @Override
    public AlarmSubscription alarms(String pattern, String whiteboard) {
        AlarmSubscriptionImpl a = new AlarmSubscriptionImpl(o, pattern,
                whiteboard == null ? "" : whiteboard);
        synchronized (lock) {
            if (!closed) {
                alarmSubs.add(a);
                return a;
            }
        }
        a.close();
        throw new ConnectionClosedException("the module is closed");
    }

    @Override
    public Optional<ReceivedSample> nextSample(Duration timeout) {
        ReceivedSample s = poll(samples, timeout);
        if (s == CLOSED_SAMPLE) {
            samples.offer(CLOSED_SAMPLE);
            return Optional.empty();
        }
        return Optional.ofNullable(s);
    }

    // -------------------------------------------------------------------------- accessors

    @Override
    public String name() {
        return name;
    }

    @Override
    public int boundPort() {
        return boundPort;
    }

    @Override
    public int listenPort() {
        return listener.port();
    }

    @Override
    public boolean legacy() {
        return legacy;
    }

    @Override
    public Optional<Capabilities> capabilities() {
        return Optional.ofNullable(capabilities);
    }

    @Override
    public Set<String> extensions() {
        return extensions;
    }

    @Override
    public boolean isConnected() {
        synchronized (lock) {
            return link != null && !closed;
        }
    }

    @Override
    public int generation() {
        synchronized (lock) {
            return generation;
        }
    }

    @Override
    public long undecodableDeliveries() {
        return undecodable.get();
    }

    @Override
    public long droppedMessages() {
        return dropped.get();
    }
}
