# negotiator in a small image (for env-server replicas; see deploy/).
FROM rust:1-slim AS build
WORKDIR /src
COPY . .
RUN cargo build --release --locked --bin negotiator

FROM debian:stable-slim
COPY --from=build /src/target/release/negotiator /usr/local/bin/negotiator
USER 65532
EXPOSE 8000
ENTRYPOINT ["negotiator"]
CMD ["env-server", "--host", "0.0.0.0", "--port", "8000"]
