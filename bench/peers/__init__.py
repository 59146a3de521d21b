"""Side-by-side benchmark of the reference server against mosquitto, NATS, Redis and amqtt."""
