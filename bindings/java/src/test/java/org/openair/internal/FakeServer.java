package org.openair.internal;

import java.io.IOException;
import java.io.OutputStream;
import java.net.InetAddress;
import java.net.ServerSocket;
import java.net.Socket;
import java.nio.charset.StandardCharsets;
import java.time.Duration;
import java.util.List;
import java.util.Map;
import java.util.Set;
import java.util.concurrent.BlockingQueue;
import java.util.concurrent.ConcurrentHashMap;
import java.util.concurrent.CopyOnWriteArrayList;
import java.util.concurrent.LinkedBlockingQueue;
import java.util.concurrent.TimeUnit;
import org.openair.Message;

/**
 * A scripted OpenAIR peer for the client tests: it plays CNS and the whiteboards on one port,
 * answers requests by type with a configurable {@link Behaviour} (the default answers every request
 * as a well-behaved server would), records every frame it receives, and can deliver to the module
 * over its callback connection.
 */
final class FakeServer implements AutoCloseable {
    /** How the server answers one request on a primary connection. */
    interface Behaviour {
        void respond(Conn conn, Message request) throws IOException;
    }

    /** A received frame: its tag, its decoded message (or null), and its connection. */
    record Received(Frame.Tag tag, Message message, Conn conn) {}

    private final ServerSocket server;
    private final List<Conn> conns = new CopyOnWriteArrayList<>();
    final BlockingQueue<Received> received = new LinkedBlockingQueue<>();
    final List<Received> history = new CopyOnWriteArrayList<>(); // every frame, never drained
    final Map<String, Behaviour> behaviours = new ConcurrentHashMap<>();
    final BlockingQueue<Conn> callbacks = new LinkedBlockingQueue<>();
    volatile boolean legacy;
    volatile Set<String> advertised = Set.of("noreply", "pipelining", "usec");
    volatile int maxInFlight = 8;
    volatile int bindPort = 0; // 0: BIND answers the port the test set with listenOn, else this

    FakeServer() throws IOException {
        this(new ServerSocket(0, 50, InetAddress.getLoopbackAddress()));
    }

    /** Serve on a listening socket the test made (for example a TLS one, spec 14.3). */
    FakeServer(ServerSocket listening) {
        server = listening;
        Thread t = new Thread(this::acceptLoop, "fake-server-accept");
        t.setDaemon(true);
        t.start();
    }

    int port() {
        return server.getLocalPort();
    }

    private void acceptLoop() {
        while (!server.isClosed()) {
            try {
                Socket s = server.accept();
                Conn c = new Conn(s);
                conns.add(c);
                Thread t = new Thread(c::readLoop, "fake-server-conn");
                t.setDaemon(true);
                t.start();
            } catch (IOException e) {
                return;
            }
        }
    }

    /** Take the next received message of {@code type} (others are skipped), or fail. */
    Received next(String type, Duration timeout) throws InterruptedException {
        long deadline = System.nanoTime() + timeout.toNanos();
        while (true) {
            long left = deadline - System.nanoTime();
            Received r = received.poll(Math.max(0, left), TimeUnit.NANOSECONDS);
            if (r == null) {
                throw new AssertionError("no " + type + " within " + timeout);
            }
            if (r.message() != null && r.message().type().equals(type)) {
                return r;
            }
        }
    }

    /** Wait for a message of {@code type}, wherever it is in the history (not consumed). */
    Received find(String type, Duration timeout) throws InterruptedException {
        long deadline = System.nanoTime() + timeout.toNanos();
        synchronized (history) {
            while (true) {
                for (Received r : history) {
                    if (r.message().type().equals(type)) {
                        return r;
                    }
                }
                long left = deadline - System.nanoTime();
                if (left <= 0) {
                    throw new AssertionError("no " + type + " within " + timeout);
                }
                TimeUnit.NANOSECONDS.timedWait(history, left);
            }
        }
    }

    /** How many messages of {@code type} arrived so far. */
    long count(String type) {
        return history.stream().filter(r -> r.message().type().equals(type)).count();
    }

    Conn callback(Duration timeout) throws InterruptedException {
        Conn c = callbacks.poll(timeout.toNanos(), TimeUnit.NANOSECONDS);
        if (c == null) {
            throw new AssertionError("no callback connection within " + timeout);
        }
        return c;
    }

    /** Close every connection the module opened (as a server restart would). */
    void dropConnections() {
        for (Conn c : conns) {
            c.close();
        }
        conns.clear();
    }

    @Override
    public void close() throws IOException {
        server.close();
        dropConnections();
    }

    static Message reply(Message request, String type, String content) {
        return Message.builder(type).sender(request.to().isEmpty() ? "CNS" : request.to())
                .to(request.sender()).isresponse(request.id()).content(content).build();
    }

    private void answer(Conn c, Message req) throws IOException {
        Behaviour b = behaviours.get(req.type());
        if (b == null) { // a waiting command carries its timeout: "WAIT_FOR_FIRST_AFTERID 500"
            b = behaviours.get(req.type().split(" ", 2)[0]);
        }
        if (b != null) {
            b.respond(c, req);
            return;
        }
        switch (req.type()) {
            case "GET_CAPABILITIES" -> c.send(legacy
                    ? reply(req, "UNKNOWN_COMMAND", "Offending cmd: GET_CAPABILITIES")
                    : capabilities(req));
            case "BIND" -> c.send(reply(req, "BIND_ACCEPT", Integer.toString(bindPort)));
            case "BIND_NOLISTEN" -> c.send(reply(req, "BIND_ACCEPT", "-1"));
            case "PING" -> c.send(reply(req, "PING_SUCCESS", ""));
            case "KEEPALIVE" -> c.send(reply(req, "KEEPALIVESUCCESS", ""));
            case "AIR.Retrieve", "AIR.Retrieves" -> c.send(Message.builder(req.type() + ".Success")
                    .sender("AIRCentral").to(req.sender()).isresponse(req.id())
                    .xmlContent("<objectcollection/>").build());
            default -> {
                if (!req.noreply()) {
                    c.send(reply(req, "RECEIVE_ACCEPT", ""));
                }
            }
        }
    }

    private Message capabilities(Message req) {
        StringBuilder sb = new StringBuilder("<capabilities protocol=\"OpenAIR/1.0\" server=\"fake\">");
        for (String ext : advertised) {
            sb.append("<extension name=\"").append(ext).append("\"/>");
        }
        sb.append("<extension name=\"future-thing\"/>"); // OA-CAP-3: ignored by the client
        sb.append("<limit name=\"max-in-flight\" value=\"").append(maxInFlight).append("\"/>");
        sb.append("</capabilities>");
        return Message.builder("CAPABILITIES").sender("CNS").to(req.sender())
                .isresponse(req.id()).xmlContent(sb.toString()).build();
    }

    /** One connection the module opened. */
    final class Conn {
        final Socket socket;
        private final FrameReader reader = new FrameReader();
        final BlockingQueue<Message> replies = new LinkedBlockingQueue<>(); // on a callback
        volatile Message notification;

        Conn(Socket socket) {
            this.socket = socket;
        }

        void readLoop() {
            byte[] buf = new byte[65536];
            try {
                while (true) {
                    int n = socket.getInputStream().read(buf);
                    if (n < 0) {
                        return;
                    }
                    reader.feed(buf, 0, n);
                    Frame f;
                    while ((f = reader.next()) != null) {
                        onFrame(f);
                    }
                }
            } catch (IOException | RuntimeException e) {
                close();
            }
        }

        private void onFrame(Frame f) throws IOException {
            Message m = f.tag() == Frame.Tag.BINARY
                    ? Message.builder("BinaryM").id("").binary(f.chunks()).build()
                    : Codec.decode(f.xml(), f.chunks(), SafeXml.DEFAULT_MAX_BYTES,
                            SafeXml.DEFAULT_MAX_DEPTH);
            Received r = new Received(f.tag(), m, this);
            synchronized (history) {
                history.add(r);
                history.notifyAll();
            }
            received.add(r);
            if (f.tag() == Frame.Tag.RECEIVE) {
                notification = m;
                callbacks.add(this);
            } else if (notification != null) {
                replies.add(m); // on a callback connection the module only answers
            } else {
                answer(this, m);
            }
        }

        synchronized void send(Message m) throws IOException {
            sendRaw(new Frame(Frame.Tag.MESSAGE, Codec.encode(m), m.binary()).encode());
        }

        synchronized void sendRaw(byte[] data) throws IOException {
            OutputStream out = socket.getOutputStream();
            out.write(data);
            out.flush();
        }

        /** Send a well-framed message whose XML is {@code xml}. */
        void sendXml(String xml) throws IOException {
            sendRaw(new Frame(Frame.Tag.MESSAGE, xml.getBytes(StandardCharsets.UTF_8), List.of())
                    .encode());
        }

        /** As the requester on a callback connection: deliver and wait for the answer. */
        Message deliver(Message m, Duration timeout) throws IOException, InterruptedException {
            send(m);
            Message answer = replies.poll(timeout.toNanos(), TimeUnit.NANOSECONDS);
            if (answer == null) {
                throw new AssertionError("no answer to " + m.type() + " within " + timeout);
            }
            return answer;
        }

        void close() {
            try {
                socket.close();
            } catch (IOException e) {
                // closed already
            }
        }
    }
}
