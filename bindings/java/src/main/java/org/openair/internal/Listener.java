package org.openair.internal;

import java.io.IOException;
import java.net.InetAddress;
import java.net.InetSocketAddress;
import java.net.ServerSocket;
import java.net.Socket;
import java.util.Set;
import java.util.concurrent.ConcurrentHashMap;
import java.util.concurrent.atomic.AtomicInteger;
import java.util.function.BiConsumer;
import java.util.function.Consumer;
import java.util.function.Function;
import java.util.function.LongSupplier;
import org.openair.ConnectionClosedException;
import org.openair.DeliveryPath;
import org.openair.OpenAirException;

/**
 * The module's receiving side: its listening socket (OA-DELIV-10) and its callback connection
 * (OA-SESS-7). A module accepts deliveries on both, from any number of connections (OA-DELIV-2).
 *
 * <p>Threading: thread-safe. One acceptor thread per listening socket; each accepted connection
 * and the callback connection get a {@link DeliveryConnection} reader thread.
 */
final class Listener {
    private final String name;
    private final DeliveryConnection.Handler handler;
    private final Function<Session.Role, Session> sessions;
    private final LongSupplier clock;
    private final Consumer<Throwable> onError;
    private final BiConsumer<String, OpenAirException> onDropped;
    private final Set<DeliveryConnection> connections = ConcurrentHashMap.newKeySet();
    private final AtomicInteger counter = new AtomicInteger();
    private ServerSocket server; // guarded by this
    private DeliveryConnection callback; // guarded by this
    private boolean closed; // guarded by this

    Listener(String name, DeliveryConnection.Handler handler, Function<Session.Role, Session> sessions, LongSupplier clock,
            Consumer<Throwable> onError, BiConsumer<String, OpenAirException> onDropped) {
        this.name = name;
        this.handler = handler;
        this.sessions = sessions;
        this.clock = clock;
        this.onError = onError;
        this.onDropped = onDropped;
    }

    /** @return the listening port, or -1 */
    synchronized int port() {
        return server == null ? -1 : server.getLocalPort();
    }

    /**
     * Listen on {@code address:port} (the port of BIND_ACCEPT, OA-DELIV-10), replacing an earlier
     * listening socket on another port.
     *
     * @param address the local interface
     * @param port the port
     */
    synchronized void listen(InetAddress address, int port) {
        if (closed) {
            throw new ConnectionClosedException("the module is closed");
        }
        if (server != null && server.getLocalPort() == port) {
            return;
        }
        stopListening();
        try {
            ServerSocket s = new ServerSocket();
            s.setReuseAddress(true);
            s.bind(new InetSocketAddress(address, port));
            server = s;
        } catch (IOException e) {
            throw new ConnectionClosedException("cannot listen on " + address.getHostAddress()
                    + ":" + port + ": " + e.getMessage());
        }
        ServerSocket s = server;
        Thread t = new Thread(() -> acceptLoop(s), "openair-" + name + "-accept");
        t.setDaemon(true);
        t.start();
    }

    private void acceptLoop(ServerSocket s) {
        while (!s.isClosed()) {
            Socket socket;
            try {
                socket = s.accept();
                socket.setTcpNoDelay(true);
            } catch (IOException e) {
                return; // closed
            }
            DeliveryConnection d = serve(socket, sessions.apply(Session.Role.RESPONDER), DeliveryPath.LISTENER);
            d.start("openair-" + name + "-delivery-" + counter.incrementAndGet());
        }
    }

    private DeliveryConnection serve(Socket socket, Session session, DeliveryPath path) {
        DeliveryConnection[] self = new DeliveryConnection[1];
        DeliveryConnection d = new DeliveryConnection(socket, session, handler, path, clock, onError,
                onDropped, () -> connections.remove(self[0]));
        self[0] = d;
        connections.add(d);
        return d;
    }

    /** Close the listening socket; connections already accepted keep being served. */
    synchronized void stopListening() {
        if (server != null) {
            try {
                server.close();
            } catch (IOException e) {
                // already closed
            }
            server = null;
        }
    }

    /**
     * Open the callback connection: one {@code Receive} frame, then serve (OA-SESS-7). An earlier
     * callback connection is closed first: the newer one replaces it.
     *
     * @param host the server host
     * @param port its main port
     * @param timeout the connect timeout
     * @param notification the RECEIVE_NAME_NOTIFICATION
     */
    void openCallback(String host, int port, java.time.Duration timeout,
            org.openair.Message notification) {
        openCallback(Link.connect(host, port, timeout), notification);
    }

    /** Make an open (and, in secure mode, proved) connection the callback one (OA-SESS-7). */
    void openCallback(Socket socket, org.openair.Message notification) {
        closeCallback();
        DeliveryConnection d = serve(socket, sessions.apply(Session.Role.REQUESTER), DeliveryPath.CALLBACK);
        d.announce(notification);
        synchronized (this) {
            if (closed) {
                d.close();
                throw new ConnectionClosedException("the module is closed");
            }
            callback = d;
        }
        d.start("openair-" + name + "-callback");
    }

    /** Close the callback connection, if one is open. */
    void closeCallback() {
        DeliveryConnection d;
        synchronized (this) {
            d = callback;
            callback = null;
        }
        if (d != null) {
            d.close();
        }
    }

    /** Close the listening socket and every delivery connection. */
    void close() {
        synchronized (this) {
            closed = true;
        }
        stopListening();
        closeCallback();
        for (DeliveryConnection d : connections) {
            d.close();
        }
    }
}
